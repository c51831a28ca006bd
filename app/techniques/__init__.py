"""The one registry of techniques: capture, the window, the benchmark, the report and the
tests all iterate REGISTRY; a technique added here appears everywhere."""
from ..errors import UserError
from .base import ROLES, Technique
from .brute import Brute
from .clustered import Clustered
from .fptl import Fptl
from .hybrid import Hybrid
from .perfect import Perfect
from .raster import Raster
from .tiled import Tiled
from .tree import Tree
from .zbin import ZBin

__all__ = ["REGISTRY", "get", "register", "unregister", "with_role", "Technique"]

REGISTRY: dict[str, Technique] = {}


def register(technique: Technique) -> Technique:
    """Add a technique (its name unique, its role known); returns it."""
    if not technique.name or technique.name in REGISTRY:
        raise ValueError(f"technique name {technique.name!r} is empty or taken")
    if technique.role not in ROLES:
        raise ValueError(f"technique {technique.name}: role {technique.role!r} not in {ROLES}")
    REGISTRY[technique.name] = technique
    return technique


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)


for _t in (Brute(), Tiled(), Clustered(), Tree(), Hybrid(), ZBin(), Fptl(), Raster(), Perfect()):
    register(_t)


def get(name: str) -> Technique:
    if name not in REGISTRY:
        raise UserError(f"unknown technique '{name}' (choose from {', '.join(REGISTRY)})")
    return REGISTRY[name]


def with_role(role: str) -> Technique:
    """The one technique of a role ("reference": the exactness check's; "floor": perfect)."""
    found = [t for t in REGISTRY.values() if t.role == role]
    if len(found) != 1:
        raise LookupError(f"{len(found)} techniques have role {role!r}")
    return found[0]
