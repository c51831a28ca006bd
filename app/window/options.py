"""Technique options in the window: the option flags given on the command line apply to
every technique that declares them.  The starting technique takes them strictly (a flag it
does not take is an error, as in capture: app.cli.options_for); a technique switched to
with a key takes the ones it declares and ignores the others, which the HUD lists."""
from __future__ import annotations


def flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def describe(value) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


class WindowOptions:
    """{option name: value} of the given flags; each technique's Options made once."""

    def __init__(self, given: dict):
        self.given = dict(given)
        self._made: dict = {}

    def for_technique(self, technique):
        """(technique.Options from the given flags it declares, names of the ignored ones)."""
        if technique.name not in self._made:
            names = set(technique.Options.names())
            taken = {k: v for k, v in self.given.items() if k in names}
            self._made[technique.name] = (technique.Options.make(taken, technique.name),
                                          tuple(sorted(set(self.given) - names)))
        return self._made[technique.name]

    def hud_line(self, technique) -> str:
        """'options: --tile 32' (the given flags this technique takes) and the ignored ones."""
        _, ignored = self.for_technique(technique)
        shown = lambda keys: "  ".join(f"{flag(k)} {describe(self.given[k])}" for k in keys)
        taken = [k for k in self.given if k not in ignored]
        text = "options: " + (shown(taken) if taken else "defaults")
        if ignored:
            text += f"   (not taken by {technique.name}: {shown(k for k in self.given if k in ignored)})"
        return text
