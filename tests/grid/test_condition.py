"""One evaluation condition, one record: its JSON, its checks, what it evaluates on."""

import pytest

from cml_edge.errors import InputError
from cml_edge.experiments.common import eval_spec
from cml_edge.grid.condition import Condition
from cml_edge.grid.maps import shipped_path, step_budget
from cml_edge.scenarios.registry import part

KEYS = ["name", "size", "obstacles", "map", "scen", "planner", "max_steps", "trials",
        "eval_seed"]


def test_the_experiments_and_the_scenarios_write_the_same_record():
    """Results written before the record existed hold these keys in this order."""
    assert list(eval_spec("e", size=12)) == KEYS
    assert list(part("p")) == [*KEYS, "age_s", "relearn_walks"]
    c = Condition("o", 12, 7, None, None, "escape", 40, 9, 5)
    assert Condition.from_dict(c.to_dict()) == c
    assert Condition.within({**part("o", size=12, obstacles=7, planner="escape",
                                     max_steps=40, trials=9), "eval_seed": 5,
                             "success_rate": 1.0}) == c


def test_the_arena_pairs_and_budget():
    ev = Condition(obstacles=20, trials=7, eval_seed=3).evaluation(12)
    assert ev.arena.size == 12 and ev.arena.n_obstacles == 20
    assert len(ev.pairs.starts) == 7 and ev.max_steps == step_budget(12)
    again = Condition(obstacles=20, trials=7, eval_seed=3).evaluation(12)
    assert (again.arena.blocked == ev.arena.blocked).all()
    assert (again.pairs.starts == ev.pairs.starts).all()
    big = Condition(size=60, trials=4, max_steps=33, planner="escape").evaluation(12)
    assert (big.arena.size, big.max_steps, big.planner) == (60, 33, "escape")
    on_map = Condition(map=str(shipped_path("maze")),
                       scen=str(shipped_path("maze", ".map.scen"))).evaluation(0)
    assert on_map.arena.size == 32 and on_map.max_steps == step_budget(32)


@pytest.mark.parametrize("fields, message", [
    ({"size": 1}, "size 1"),
    ({"obstacles": -1}, "obstacles -1"),
    ({"trials": 0}, "trials 0"),
    ({"max_steps": 0}, "max_steps 0"),
    ({"eval_seed": True}, "eval_seed True"),
    ({"planner": "astar"}, "unknown planner 'astar'"),
    ({"map": ""}, "map '' is not a file name"),
    ({"scen": "x.scen"}, "a scen file needs a map"),
    ({"map": "maze", "size": 32}, "give size or map, not both"),
    ({"map": "maze", "obstacles": 3}, "not on a map"),
    ({"name": 3}, "condition name 3"),
])
def test_bad_conditions_are_one_line_errors(fields, message):
    with pytest.raises(InputError, match=message):
        Condition(**fields)
    with pytest.raises(InputError, match="unknown evaluation condition keys: age_s"):
        Condition.from_dict({"age_s": 1.0})
