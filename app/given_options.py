"""The option flags given on the command line, applied to every technique that declares
them (the window and the bench's camera-path run): the starting technique takes them
strictly (a flag it does not take is an error, as in capture: app.cli.options_for); a
technique switched to takes the ones it declares and ignores the others, which the HUD
lists.  The window's panel then changes one technique's options (its own declarations:
app.techniques.options OptionSpec), checked as on the command line; the next frame renders
with them.  No GL, nothing of the window."""
from __future__ import annotations


def flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def describe(value) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


_UNSET = object()          # set(): the option had no panel change before


class GivenOptions:
    """{option name: value} of the given flags, and each technique's Options (the given
    flags it declares, then the panel's changes)."""

    def __init__(self, given: dict):
        self.given = dict(given)
        self._made: dict = {}
        self.changed: dict[str, dict] = {}       # technique -> {option: value} from the panel

    def for_technique(self, technique):
        """(technique.Options from the given flags it declares and the panel's changes,
        names of the given flags it ignores)."""
        if technique.name not in self._made:
            names = set(technique.Options.names())
            taken = {k: v for k, v in self.given.items() if k in names}
            taken.update(self.changed.get(technique.name, {}))
            self._made[technique.name] = (technique.Options.make(taken, technique.name),
                                          tuple(sorted(set(self.given) - names)))
        return self._made[technique.name]

    def set(self, technique, name: str, value):
        """Change one option of one technique (checked: a UserError names the flag and its
        range); returns the value as stored."""
        spec = {s.name: s for s in technique.Options.specs()}.get(name)
        if spec is None:
            from .errors import UserError
            raise UserError(f"{technique.name} has no option {flag(name)}")
        value = spec.check(value, technique.name)
        mine = self.changed.setdefault(technique.name, {})
        before = mine.get(name, _UNSET)
        mine[name] = value
        self._made.pop(technique.name, None)
        try:                 # the combination too: an option the new mode ignores is refused
            self.for_technique(technique)
        except Exception:
            if before is _UNSET:
                del mine[name]
            else:
                mine[name] = before
            self._made.pop(technique.name, None)
            raise
        return value

    def reset(self, technique) -> None:
        """Back to the given flags and the declared defaults."""
        self.changed.pop(technique.name, None)
        self._made.pop(technique.name, None)

    def hud_line(self, technique) -> str:
        """'options: --tile 32' (the given flags this technique takes, and the panel's
        changes) and the ignored ones."""
        opts, ignored = self.for_technique(technique)
        specs = {s.name: s for s in technique.Options.specs()}

        def value(k, v) -> str:      # a choice by its name, quoted as a shell would take it
            s = specs.get(k)
            return f'"{s.label(s.check(v))}"' if s is not None and s.choices else describe(v)
        shown = lambda keys, src: "  ".join(f"{flag(k)} {value(k, src[k])}" for k in keys)
        taken = {k: v for k, v in self.given.items() if k not in ignored}
        taken.update(self.changed.get(technique.name, {}))
        text = "options: " + (shown(taken, taken) if taken else "defaults")
        if ignored:
            text += f"   (not taken by {technique.name}: {shown([k for k in self.given if k in ignored], self.given)})"
        return text
