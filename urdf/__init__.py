"""URDF descriptions shipped with ibvs-youla (installed as ``ibvs_youla.urdf``)."""
