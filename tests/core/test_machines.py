"""The cross-machine promise (cml_edge.core.machines): integers exact, floats within the
tolerance, keys in order."""

import math

from cml_edge.core.machines import ABS, REL, close, differences


def test_floats_match_within_the_tolerance_and_nothing_else_does():
    assert close(1.0, 1.0 + 0.5 * REL) and not close(1.0, 1.0 + 2 * REL)
    assert close(1.2e-17, 1.4e-17)  # the rounding floor: ABS
    assert not close(0.0, 2 * ABS)
    assert close(math.nan, math.nan) and not close(math.nan, 0.0)
    want = {"a": 1, "b": [0.5, None, "x"], "c": {"d": True}}
    assert differences({"a": 1, "b": [0.5 + 1e-12, None, "x"], "c": {"d": True}}, want) == []
    assert differences({"a": 2, "b": [0.5, None, "x"], "c": {"d": True}}, want) == [
        ".a: 2 where 1 is expected"]
    assert differences({"b": [0.5, None, "x"], "a": 1, "c": {"d": True}}, want)[0].startswith(
        ".: keys ['b', 'a', 'c']")
    assert differences({"a": 1.0, "b": [0.5, None, "x"], "c": {"d": True}}, want) == [
        ".a: 1.0 where 1 is expected"]  # an integer stays an integer
    assert differences({"a": 1, "b": [0.5, None], "c": {"d": True}}, want)[0].startswith(".b:")
    assert differences({"a": 1, "b": [0.5, None, "x"], "c": {"d": 1}}, want) == [
        ".c.d: 1 where True is expected"]
