# pneumatic.load and Model: cylinders with their parameters and log columns, parameters read and set by
# key as the MJCF is checked, copies that step like their original.
import numpy as np
import pytest

import pneumatic


def test_load_lists_the_cylinders_with_their_parameters_and_columns(models):
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    [cyl] = model.cylinders
    assert cyl.name == "cyl"
    valve = cyl.parameters["valve"]
    assert valve.value == "proportional_per_chamber"
    assert valve.valid == "onoff proportional_5_3 proportional_per_chamber"
    supply = cyl.parameters["p_supply"]
    assert supply.unit == "Pa abs" and supply.value == model.get("cyl:p_supply")
    # a chamber key is listed once per chamber
    assert "P.dead_volume" in cyl.parameters and "N.dead_volume" in cyl.parameters
    assert [c.name for c in cyl.commands] == ["cyl.uP", "cyl.uN"]
    assert [c.name for c in cyl.measured] == ["cyl.p_P", "cyl.p_N", "cyl.x", "cyl.v", "cyl.p_S"]
    assert cyl.measured[0].unit == "Pa" and cyl.measured[0].kind == "measured"


def test_the_humanoid_has_36_cylinders(models):
    model = pneumatic.load(str(models / "humanoid_pneumatic.xml"))
    assert len(model.cylinders) == 36


def test_a_refused_file_raises_value_error_with_the_message(tmp_path):
    with pytest.raises(ValueError, match="nothing.xml"):
        pneumatic.load(str(tmp_path / "nothing.xml"))


def test_set_then_get_returns_the_value_set(models):
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    model.set("cyl:dead_volume", 3e-6)  # both chambers
    assert model.get("cyl:P.dead_volume") == 3e-6 and model.get("cyl:N.dead_volume") == 3e-6
    model.set("cyl:P.dead_volume", 2.5e-6)
    assert model.get("cyl:P.dead_volume") == 2.5e-6 and model.get("cyl:N.dead_volume") == 3e-6
    assert model.cylinders[0].parameters["P.dead_volume"].value == 2.5e-6


def test_a_bad_value_raises_value_error_naming_cylinder_and_key_and_leaves_the_model(models):
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    before = model.get("cyl:p_supply")
    with pytest.raises(ValueError) as refused:
        model.set("cyl:p_supply", -5.0)
    assert "'cyl'" in str(refused.value) and "p_supply" in str(refused.value)
    assert model.get("cyl:p_supply") == before
    with pytest.raises(ValueError, match="unknown|no cylinder|'nope'"):
        model.get("nope:stroke")
    with pytest.raises(ValueError, match="<cylinder>:<key>"):
        model.get("stroke")


def test_the_same_refusal_as_the_mjcf(models, tmp_path):
    # the value the setter refuses, written into the MJCF text, is refused by load with the same reason
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    with pytest.raises(ValueError) as by_set:
        model.set("cyl:stroke", 20.0)
    text = (models / "rig_per_chamber.xml").read_text()
    configuration = model.configuration("cyl")
    assert "stroke=" in configuration
    old = [part for part in configuration.split() if part.startswith("stroke=")][0]
    assert old in text
    (tmp_path / "bad.xml").write_text(text.replace(old, "stroke=20"))
    with pytest.raises(ValueError) as by_load:
        pneumatic.load(str(tmp_path / "bad.xml"))
    assert str(by_set.value) in str(by_load.value)


def test_a_copy_steps_bit_for_bit_like_its_original(models):
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    model.set("cyl:dead_volume", 3e-6)
    copy = model.copy()
    assert copy.get("cyl:P.dead_volume") == 3e-6
    a, b = pneumatic.Simulation(model), pneumatic.Simulation(copy)
    for sim in (a, b):
        sim.ctrl[sim.command("cyl.uP")], sim.ctrl[sim.command("cyl.uN")] = 7.5, 2.5
        sim.step(500)
    assert a.time == b.time
    assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.qvel, b.qvel) and np.array_equal(a.act, b.act)
    # and it is a copy: a change to it leaves the original
    copy.set("cyl:dead_volume", 4e-6)
    assert model.get("cyl:P.dead_volume") == 3e-6
