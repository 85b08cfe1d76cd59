"""JSON as the commands write it (``--json``, ``results.json``): strict JSON (RFC 8259), which
has no NaN or infinity. Python's :func:`json.dumps` writes a float NaN as the bare word
``NaN``, which ``JSON.parse``, ``jq`` and most parsers outside Python refuse, failing the whole
document; a figure that is not defined (the speed of a run on windows without one event) is
written as ``null`` instead."""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["document", "dumps", "strict"]


def strict(value: Any) -> Any:
    """``value`` with every float that is not finite, in dicts, lists and tuples at any depth,
    replaced by ``None``."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: strict(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict(item) for item in value]
    return value


def dumps(value: Any, *, indent: int | None = None) -> str:
    """``value`` as strict JSON (:func:`strict`; refused by :func:`json.dumps` should a value
    that is not finite remain)."""
    return json.dumps(strict(value), indent=indent, allow_nan=False)


def document(value: dict[str, Any], *, indent: int | None = 2) -> str:
    """A command's JSON document (``--json``): ``value`` led by ``"uavsnn"``, the version that
    wrote it, so that a program reading it knows which layout it holds (a document's keys are
    only added to within a minor version)."""
    from uavsnn import __version__

    return dumps({"uavsnn": __version__, **value}, indent=indent)
