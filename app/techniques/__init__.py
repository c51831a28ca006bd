"""The one registry of techniques: capture, the window, the benchmark and the tests all
iterate REGISTRY; a technique added here appears everywhere."""
from .base import Build, FrameInput, Options, Technique
from .brute import Brute
from .clustered import Clustered
from .hybrid import Hybrid
from .tiled import Tiled
from .tree import Tree

__all__ = ["REGISTRY", "get", "Build", "FrameInput", "Options", "Technique"]

REGISTRY: dict[str, Technique] = {t.name: t for t in (Brute(), Tiled(), Clustered(), Tree(), Hybrid())}


def get(name: str) -> Technique:
    if name not in REGISTRY:
        from ..errors import UserError
        raise UserError(f"unknown technique '{name}' (choose from {', '.join(REGISTRY)})")
    return REGISTRY[name]
