"""The bench commands' list arguments (--lights, --sweep, --threads, ...), parsed one way."""
from __future__ import annotations

from ..errors import UserError


def int_list(text: str, what: str) -> tuple[int, ...]:
    try:
        vals = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UserError(f"{what} must be comma-separated integers (got '{text}')") from None
    if not vals or min(vals) < 0:
        raise UserError(f"{what} must be non-negative integers (got '{text}')")
    return vals


__all__ = ["int_list"]
