"""Rows of the table-driven bad-input tests: a call, the error it must raise, the name it must say."""

from __future__ import annotations

import pytest


def case(call, error, name, id_):
    """One row: ``call()`` must raise ``error`` with ``name`` in its message."""
    return pytest.param(call, error, name, id=id_)


def check(call, error, name):
    """Run one row: the error type, and the argument named in its message; returns the error."""
    with pytest.raises(error) as info:
        call()
    assert name in str(info.value), f"{name!r} not named in: {info.value}"
    return info.value
