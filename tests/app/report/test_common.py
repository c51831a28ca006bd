"""The report's shared pieces: every technique its own colour."""
from app.report.common import Colors, Roles
from app.techniques import REGISTRY


def test_every_technique_has_its_own_colour_and_the_first_ten_are_tab10s():
    import matplotlib
    roles = Roles.from_registry()
    names = list(REGISTRY) + [f"extra{i}" for i in range(6)]      # more than twenty would repeat
    c = Colors(names, roles)
    assert len({c(t) for t in names}) == len(names)
    others = [t for t in names if t != roles.floor]
    tab10 = matplotlib.colormaps["tab10"]
    assert [c(t) for t in others[:10]] == [tab10(i) for i in range(10)]
    assert c(roles.floor) == (0, 0, 0, 1)
