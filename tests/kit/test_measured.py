"""A device from measurements: the file checked before anything, the fit recovering the
generator's physics, the device keeping the contract, and its characterisation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cml_edge.backends import check_device, register_device, unregister_device
from cml_edge.data import make_device_data as gen
from cml_edge.errors import InputError
from cml_edge.kit.measured import Characterization, fit, from_measurements, read_measurements

SHIPPED = Path(gen.__file__).parent / "devices" / "ecram_pulses.csv"


def test_the_shipped_file_is_what_its_script_writes(tmp_path):
    assert SHIPPED.read_text() == "\n".join(gen.rows()) + "\n"


def test_the_fit_recovers_the_generators_physics():
    f = fit(read_measurements(SHIPPED))
    to_g = (gen.G_HI - gen.G_LO) / (gen.W_MAX - gen.W_MIN)  # uS per weight unit
    # the up step at the bottom of the range: dw_min (1 - gamma_up w_min / w_max)
    w = gen.W_MIN + (f.grid[0] - gen.G_LO) / to_g
    want = gen.DW_MIN * (1 - gen.GAMMA_UP * w / gen.W_MAX) * to_g
    assert f.up[0] == pytest.approx(want, rel=0.1)
    # down steps grow toward the top (gamma_down), up steps shrink (gamma_up)
    assert abs(f.down[-1]) > 1.3 * abs(f.down[0]) and f.up[-1] < f.up[0]
    # cycle-to-cycle: 30 % of the step; device-to-device: 10 % (three devices: loosely)
    assert np.median(f.up_std / f.up) == pytest.approx(gen.C2C, rel=0.15)
    assert 0.02 < f.d2d_up < 0.25


@pytest.mark.parametrize("text, message", [
    ("device,cycle,pulse,conductance\n", "header 'device,cycle,pulse,conductance'"),
    ("device,cycle,direction,pulse,conductance\n", "has no rows"),
    ("device,cycle,direction,pulse,conductance\nd,1,sideways,0,1\n",
     "line 2: direction 'sideways'"),
    ("device,cycle,direction,pulse,conductance\nd,1,up,0,1,9\n", "line 2: 6 fields"),
    ("device,cycle,direction,pulse,conductance\nd,1,up,0,nan\n", "line 2: conductance 'nan'"),
    ("device,cycle,direction,pulse,conductance\nd,1,up,zero,1\n", "pulse 'zero'"),
    ("device,cycle,direction,pulse,conductance\n" + "".join(
        f"d,1,up,{k},{k}\n" for k in (0, 1, 2, 4)), "not 0, 1, 2, ... without gaps"),
    ("device,cycle,direction,pulse,conductance\n" + "".join(
        f"d,1,up,{k},{k}\n" for k in range(3)), "has 3 pulses"),
    ("device,cycle,direction,pulse,conductance\n" + "".join(
        f"d,1,up,{k},{k}\n" for k in range(5)), "has no down trace"),
])
def test_a_bad_measurement_file_is_one_line(tmp_path, text, message):
    path = tmp_path / "m.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        read_measurements(path)
    assert "\n" not in str(err.value)


def test_a_missing_or_flat_file_is_refused(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_measurements(tmp_path / "none.csv")
    flat = tmp_path / "flat.csv"
    flat.write_text("device,cycle,direction,pulse,conductance\n" + "".join(
        f"d,1,{d},{k},5\n" for d in ("up", "down") for k in range(6)))
    with pytest.raises(InputError, match="the conductance does not change"):
        fit(read_measurements(flat))


@pytest.fixture(scope="module")
def lab():
    spec = from_measurements("lab-test", SHIPPED)
    register_device(spec)
    yield spec
    unregister_device(spec)


def test_the_measured_device_keeps_the_contract(lab):
    check_device(lab)


def test_its_characterisation_follows_the_data(lab):
    r = Characterization().run(lab, {}, 500, 0)
    assert r["rows_total"] == 20 and r["within"] == 20
    up = r["curves"]["up"]
    assert len(up["model_mean"]) == gen.PULSES + 1
    assert abs(up["model_mean"][-1] - up["data_mean"][-1]) < 0.05 * (gen.G_HI - gen.G_LO)
    # without the spreads the devices move as one
    still = Characterization().run(lab, {"c2c_scale": 0.0, "d2d_scale": 0.0}, 50, 0)
    assert still["curves"]["up"]["model_std"][-1] < 0.3 * up["model_std"][-1]
    json.dumps(r)  # JSON-able


def test_a_model_carries_its_table(lab, tmp_path):
    from cml_edge.core.cml import CML, CMLConfig
    from cml_edge.core.model_file import load_model, save_model

    cml = CML.create(CMLConfig.for_arena(8), "lab-test", 0)
    save_model(tmp_path / "m.npz", cml, {})
    with np.load(tmp_path / "m.npz") as z:
        assert np.array_equal(z["W_k/up"], lab.array_class.fitted.up)
    back, _ = load_model(tmp_path / "m.npz")
    assert np.array_equal(back.W_k.to_float(), cml.W_k.to_float())
