"""app.pipeline.phases: a run's time by named phase, nested phases exclusive, moved time counted once."""
import time

from app.pipeline import phases
from app.report.runtime import time_lines as report_lines
from app.bench.study import phase_text, time_lines


def test_a_nested_phase_stops_the_outer_ones_clock():
    before = phases.snapshot()
    with phases.phase("outer-test"):
        time.sleep(0.02)
        with phases.phase("inner-test"):
            time.sleep(0.05)
        time.sleep(0.02)
    spent = phases.since(before)
    assert 0.04 <= spent["outer-test"] < 0.05 + 0.04      # its own 40 ms, not the inner's
    assert 0.05 <= spent["inner-test"] < 0.09
    assert list(spent)[0] == "inner-test"                  # the longest first


def test_moved_time_leaves_the_open_phase():
    before = phases.snapshot()
    with phases.phase("render-test"):
        t0 = time.perf_counter()
        time.sleep(0.05)
        phases.move("compile-test", time.perf_counter() - t0)
    spent = phases.since(before)
    assert spent["compile-test"] >= 0.05
    assert spent.get("render-test", 0.0) < 0.02


def test_a_decorated_function_is_its_phase():
    @phases.timed("check-test")
    def work(x):
        time.sleep(0.02)
        return x + 1
    before = phases.snapshot()
    assert work(1) == 2
    assert phases.since(before)["check-test"] >= 0.02


def test_the_time_lines_name_each_studys_phases():
    lines = time_lines({"rendered": 4.0, "cpu": 1.0},
                       {"rendered": {"compile": 1.0, "render": 2.5, "other": 0.5}})
    assert "80.0%" in lines[0] and lines[0].endswith("(render 2.5 s, compile 1.0 s, other 0.5 s)")
    assert lines[1].endswith("%")                          # no phases: none named
    assert phase_text({}) == ""


def test_the_reports_run_section_says_where_the_time_went():
    info = {"study_s": {"rendered": 30.0, "cpu": 5.0}, "report_s": 5.0,
            "phase_s": {"rendered": {"render": 20.0, "check": 10.0}}}
    lines = report_lines(info)
    assert lines[1] == "  - rendered: 30.0 s (85.7%): render 20.0 s, check 10.0 s"
    assert lines[2] == "  - cpu: 5.0 s (14.3%)" and len(lines) == 3    # report_s: not known yet
    assert report_lines({}) == []                          # an older run.json: no line
