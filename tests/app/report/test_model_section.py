"""The report's cost-model section (app/report/model.py): the sensitivity table re-judges a
claim under each assumption moved, and names the claims whose verdict moves."""
from __future__ import annotations

from app.model import cost
from app.report import model as section


def test_a_verdict_that_rests_on_an_assumption_is_fragile():
    g = cost.BY_KEY["gtx980"]
    div = cost.ASSUMED["int_division"].value

    def judge(rows, ms):        # a claim that holds only while a division costs > 0.8 x div
        slots = cost.slots([0, 0, 1, 0], g) - 1 / g.sfu
        return [("steady", "always", "agrees"),
                ("divides", "divisions are dear", "agrees" if slots > 0.8 * div else "close")]

    table, words = section.sensitivity([], judge)
    rows = {line.split(" | ")[0].strip("| "): line for line in table.splitlines()[2:]}
    assert set(rows) == {"steady", "divides"}
    assert "close" not in rows["steady"]
    assert rows["divides"].count("close") == 1        # at int_division -30% alone
    assert len(words) == 1 and "**fragile**: divides (agrees) becomes close at int_division -30%" in words[0]
    assert cost.slots([0, 0, 1, 0], g) - 1 / g.sfu == div      # every setting restored


def test_no_fragile_claim_says_so():
    table, words = section.sensitivity([], lambda rows, ms: [("a", "t", "close")])
    assert words == ["No verdict changes when any one assumption moves by 30%."]
    assert table.count("=") == 2 * len(cost.ASSUMED)
