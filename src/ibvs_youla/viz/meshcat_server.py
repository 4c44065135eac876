"""Reaching a running meshcat server by its ZeroMQ URL, with a time limit meshcat itself does not have.

``meshcat.Visualizer(zmq_url=...)`` sends the server a ``url`` request and blocks on the answer,
forever when nothing listens at that address. :func:`wait_for_server` sends the same request on
a socket of its own and waits at most ``timeout``; :class:`~.meshcat_viewer.Viewer` and
``ibvs-youla view --zmq-url URL --zmq-timeout S`` call it first. pyzmq (a dependency of
meshcat) is imported when it is called, so importing this module stays cheap.
"""

from __future__ import annotations

import time

from .._validation import positive
from ..exceptions import InvalidParameterError, VisualizationError

__all__ = ["CONNECT_TIMEOUT", "wait_for_server"]

CONNECT_TIMEOUT = 5.0  # [s] default wait for the answer of a meshcat server given by its URL


def wait_for_server(
    zmq_url: str, timeout: float = CONNECT_TIMEOUT, *, names: tuple[str, str] = ("zmq_url", "connect_timeout")
) -> str:
    """The web URL of the meshcat server at ``zmq_url``, asked for over ZeroMQ within ``timeout`` [s].

    Args:
        zmq_url: ZeroMQ endpoint of a running ``meshcat-server``, e.g. ``tcp://127.0.0.1:6000``.
        timeout: How long to wait for the answer [s], > 0.
        names: How the caller spells (``zmq_url``, ``timeout``) in messages, e.g. the CLI flags.

    Raises:
        InvalidParameterError: ``zmq_url`` is not a string ZeroMQ can connect to, or ``timeout``
            is not a finite number > 0.
        VisualizationError: pyzmq is not installed, or no server answered within ``timeout``.
    """
    timeout = positive(timeout, names[1], unit="[s]")
    if not isinstance(zmq_url, str):
        raise InvalidParameterError(names[0], zmq_url, "a ZeroMQ endpoint such as 'tcp://127.0.0.1:6000'")
    try:
        import zmq
    except ImportError as exc:
        raise VisualizationError(f"{names[0]} needs pyzmq (pip install 'ibvs-youla[viz]'): {exc}") from exc
    socket = zmq.Context.instance().socket(zmq.REQ)
    try:
        socket.setsockopt(zmq.LINGER, 0)
        try:
            socket.connect(zmq_url)
        except zmq.ZMQError as exc:
            valid = f"a ZeroMQ endpoint such as 'tcp://127.0.0.1:6000' (ZeroMQ: {exc})"
            raise InvalidParameterError(names[0], zmq_url, valid) from None
        deadline = time.monotonic() + timeout
        for event in (zmq.POLLOUT, zmq.POLLIN):  # the request can be queued; the answer has come
            if not socket.poll(max(deadline - time.monotonic(), 0.0) * 1000.0, event):
                raise VisualizationError(
                    f"{names[0]} {zmq_url!r}: no meshcat server answered within {timeout:g} s "
                    f"({names[1]}); start one with meshcat-server, or omit {names[0]} to start a local one"
                )
            if event == zmq.POLLOUT:
                socket.send(b"url")
        return socket.recv().decode("utf-8")
    finally:
        socket.close(linger=0)
