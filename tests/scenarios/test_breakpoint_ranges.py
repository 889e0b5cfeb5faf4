"""Break points: every knob's default range is valid on every device it applies to, a
range that does not bracket the target is a result, and a knob's field given twice is
refused."""

import re

import pytest

from cml_edge.backends import DEVICES
from cml_edge.errors import InputError
from cml_edge.scenarios import breakpoint as bp


def test_every_default_range_is_valid_for_every_backend_that_leaves_the_field_free():
    for name, device in DEVICES.items():
        for knob in bp.knobs_of(name).values():
            if knob.field == bp.IDLE:
                continue
            for backend in device.backends:
                if any(f in device.fixes(backend) for f in knob.fields):
                    continue
                for value in bp.knob_grid(knob, knob.lo, knob.hi):
                    device.given(backend, knob.setting(value))  # raises if refused


def fake_scenario(success):
    """A stand-in for run_scenario whose success is ``success(knob value)``."""
    def run(scenario, backend, options, seeds, budget, out, workers, scheduler, idle_s,
            restart=False):
        value = options.get("read_noise", idle_s)
        return {"scenario": scenario, "parts": [{"part": "p", "success_rate": success(value)}]}
    return run


@pytest.mark.parametrize("success, why", [
    (lambda v: 1.0, "success meets the target across it"),
    (lambda v: 0.0, "success is below the target even at the good end"),
    (lambda v: v, "success rises toward the bad end")])
def test_a_range_that_does_not_bracket_is_a_result(monkeypatch, success, why):
    monkeypatch.setattr(bp, "run_scenario", fake_scenario(success))
    r = bp.find_breakpoint("paper", "crossbar", "read_noise", target=0.5, seeds=2)
    assert r["found"] is False and r["value"] is None and r["bracket"] is None
    assert r["note"].startswith("no break point within the physical range 0..0.5 of "
                                "read_noise at target 0.5: " + why)
    assert r["n_evaluations"] == 2 == len(r["evaluations"])
    given = bp.find_breakpoint("paper", "crossbar", "read_noise", target=0.5, seeds=2,
                               value_range=(0.0, 0.25))
    assert given["note"].startswith("no break point within the range 0..0.25")


def test_a_bracketed_range_finds_the_last_passing_value(monkeypatch):
    monkeypatch.setattr(bp, "run_scenario", fake_scenario(lambda v: 1.0 - v))
    r = bp.find_breakpoint("paper", "crossbar", "read_noise", target=0.8, seeds=2)
    assert r["found"] and r["value"] == 0.1875 and r["bracket"] == [0.1875, 0.21875]


def test_a_knob_field_given_too_is_refused():
    with pytest.raises(InputError, match=r"read_noise is given \(read_noise=0.1\) and set by "
                                         r"--knob read_noise"):
        bp.find_breakpoint("paper", "crossbar", "read_noise", {"read_noise": 0.1})
    with pytest.raises(InputError, match="stuck_low is given"):
        bp.find_breakpoint("paper", "crossbar", "stuck", {"stuck_low": 0.1})


def test_the_command_reports_no_break_point_with_exit_0(monkeypatch, cli):
    monkeypatch.setattr(bp, "run_scenario", fake_scenario(lambda v: 1.0))
    code, out, err = cli("breakpoint", "--knob", "read_noise", "--scenario", "paper",
                         "--backend", "crossbar", "--seeds", "2")
    assert code == 0 and "no break point within the physical range" in out
    code, out, err = cli("breakpoint", "--knob", "read_noise", "--scenario", "paper",
                         "--backend", "crossbar", "--set", "read_noise=0.1")
    assert code == 2 and "set by --knob read_noise" in err and len(err.splitlines()) == 1


@pytest.mark.parametrize("knob, value_range, words", [
    ("read_noise", (0.0, 1e308), "read_noise 1e+308 is outside its range 0..1"),
    ("drift_time", (1.0, 1e308), "outside 0..3.15576e+09 seconds"),
    ("levels", (2, 100000), "levels 100000 is outside its range 0..4096")])
def test_a_range_beyond_the_field_is_refused(knob, value_range, words):
    with pytest.raises(InputError, match=re.escape(words)):
        bp.find_breakpoint("paper", "crossbar", knob, value_range=value_range)


def test_the_largest_rise_toward_the_bad_end_is_named(monkeypatch, cli):
    """Success that rises toward the bad end (a dip at 0.25 here) is reported: the result's
    largest_rise and a line of the command's output; a falling success has none."""
    monkeypatch.setattr(bp, "run_scenario", fake_scenario(lambda v: 1.0 - v))
    assert bp.find_breakpoint("paper", "crossbar", "read_noise", target=0.8,
                              seeds=2)["largest_rise"] is None
    monkeypatch.setattr(bp, "run_scenario",
                        fake_scenario(lambda v: 0.25 if v == 0.25 else 1.0 - v))
    r = bp.find_breakpoint("paper", "crossbar", "read_noise", target=0.8, seeds=2)
    assert [e["value"] for e in r["evaluations"]][:3] == [0.0, 0.5, 0.25]
    assert r["largest_rise"] == {"from": 0.25, "to": 0.5, "by": 0.25}
    assert r["value"] == 0.1875  # the bisection's answer is unchanged: the rise is named
    code, out, _ = cli("breakpoint", "--knob", "read_noise", "--scenario", "paper",
                       "--backend", "crossbar", "--seeds", "2", "--target", "0.8")
    assert code == 0 and "success rose 0.250 from 0.25 to 0.5, toward the bad end" in out


def test_the_bad_end_is_where_the_second_evaluation_was():
    """A knob whose good end is its high value (levels): toward the bad end is downward."""
    evals = [{"value": v, "success_rate": s} for v, s in
             ((1001, 1.0), (2, 0.1), (45, 0.6), (212, 0.9), (97, 0.95))]
    assert bp.largest_rise(evals) == {"from": 212, "to": 97, "by": pytest.approx(0.05)}
    assert bp.largest_rise(evals[:2]) is None and bp.largest_rise(evals[:1]) is None
