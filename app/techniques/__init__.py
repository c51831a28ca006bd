"""The one registry of techniques: capture, the window, the benchmark, the report and the
tests all iterate REGISTRY.  Every module of this package is imported here, in name order,
and a technique's class registers itself at its place (`class X(Technique, register_at=N)`,
app.techniques.base): adding a technique is adding its module, no edit here."""
from importlib import import_module
import pkgutil

from ..errors import UserError
from .base import REGISTRY, ROLES, Technique, register, unregister

__all__ = ["REGISTRY", "discover", "get", "register", "unregister", "with_role", "Technique"]


def discover(package: str) -> list[str]:
    """Import every module of `package`, in name order (their techniques register
    themselves; the registry orders them by place); returns the modules' names."""
    pkg = import_module(package)
    names = sorted(m.name for m in pkgutil.iter_modules(pkg.__path__))
    for name in names:
        import_module(f"{package}.{name}")
    return names


discover(__name__)


def get(name: str) -> Technique:
    if name not in REGISTRY:
        raise UserError(f"unknown technique '{name}' (choose from {', '.join(REGISTRY)})")
    return REGISTRY[name]


def with_role(role: str) -> Technique:
    """The one technique of a role ("reference": the exactness check's; "floor": perfect)."""
    found = [t for t in REGISTRY.values() if t.role == role]
    if len(found) != 1:
        raise LookupError(f"{len(found)} techniques have role {role!r}")
    assert role in ROLES, role
    return found[0]
