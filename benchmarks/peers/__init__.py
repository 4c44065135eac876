"""Peer libraries timed beside ibvs-youla on the same work: their harnesses and how to build or install them.

Never a dependency of the package: each peer is built or installed by the benchmark that times it
(:mod:`.visp`: a C++ harness against Debian's ``libvisp-dev``, found with pkg-config; :mod:`.mvtb`:
the Machine Vision Toolbox for Python in a throwaway virtual environment).
"""
