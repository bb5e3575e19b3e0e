"""Helpers shared by the test modules."""
from __future__ import annotations

import contextlib
import re

import pytest


@contextlib.contextmanager
def _raises_naming(exc, *names: str):
    """``pytest.raises(exc)`` that also checks that the message names every one of ``names``
    (whole words, so ``n`` does not match inside ``integrand``)."""
    with pytest.raises(exc) as info:
        yield info
    message = str(info.value)
    for name in names:
        assert re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", message), \
            f"the message does not name {name!r}: {message!r}"


@pytest.fixture
def raises_naming():
    """Context manager: ``with raises_naming(ValueError, "alpha"): ...`` fails unless the
    block raises ``ValueError`` whose message names ``alpha``."""
    return _raises_naming
