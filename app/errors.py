"""User-facing errors: each prints as one line, exit status 2, no traceback."""
import sys
from typing import NoReturn


class UserError(Exception):
    """Bad input or an unavailable platform feature, explained in one line."""


class FrameTimeout(UserError):
    """A frame stopped between two of its passes at its deadline (Renderer.render(deadline=))."""


def exit_with(message: str, status: int = 2) -> NoReturn:
    print(f"error: {' '.join(str(message).split())}", file=sys.stderr)
    raise SystemExit(status)
