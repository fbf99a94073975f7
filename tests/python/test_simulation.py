# pneumatic.Simulation: mj_step from Python, numpy views that alias MuJoCo's memory, absolute pressures.
import numpy as np
import pytest

import pneumatic


def drive(sim, u_P, u_N):
    sim.ctrl[sim.command("cyl.uP")] = u_P
    sim.ctrl[sim.command("cyl.uN")] = u_N


@pytest.fixture
def rig(models):
    return pneumatic.load(str(models / "rig_per_chamber.xml"))


def test_starts_at_atmospheric_pressure_and_zero_time(rig):
    sim = pneumatic.Simulation(rig)
    assert sim.time == 0
    p_atm = rig.get("cyl:p_atm")
    assert np.array_equal(sim.pressures(), [[p_atm, p_atm]])
    assert sim.pressure("cyl", "P") == p_atm
    # the activations are gauge pressures
    assert np.array_equal(sim.act[:2], [0.0, 0.0])


def test_views_alias_mujoco_memory(rig):
    sim = pneumatic.Simulation(rig)
    ctrl = sim.ctrl
    assert ctrl.flags.writeable and not ctrl.flags.owndata
    # a command written through the view drives the step: valve P fully open to the supply (10 V), valve N
    # to the exhaust (0 V); after 0.2 s chamber P is near the 620 kPa supply, N near the 100 kPa exhaust
    ctrl[sim.command("cyl.uP")] = 10.0
    ctrl[sim.command("cyl.uN")] = 0.0
    sim.step(200)
    p_P, p_N = sim.pressures()[0]
    assert p_P > 0.9 * rig.get("cyl:p_supply") and p_N < 1.1 * rig.get("cyl:p_exhaust")
    # the same memory through a second view, and the state written through qpos is MuJoCo's
    assert sim.ctrl[sim.command("cyl.uP")] == 10.0
    sim.qpos[:] = 0.01
    assert np.all(sim.qpos == 0.01)
    assert abs(sim.time - 200 * rig.timestep) < 1e-12


def test_step_n_is_n_steps_of_one(rig):
    a, b = pneumatic.Simulation(rig), pneumatic.Simulation(rig)
    for sim in (a, b):
        drive(sim, 8.0, 3.0)
    a.step(100)
    for _ in range(100):
        b.step()
    assert a.time == b.time and np.array_equal(a.act, b.act) and np.array_equal(a.qpos, b.qpos)


def test_reset_returns_to_the_initial_state(rig):
    sim = pneumatic.Simulation(rig)
    start = (sim.qpos.copy(), sim.act.copy())
    drive(sim, 9.0, 1.0)
    sim.step(50)
    sim.reset()
    assert sim.time == 0 and np.array_equal(sim.qpos, start[0]) and np.array_equal(sim.act, start[1])


def test_assignment_checks_the_size(rig):
    sim = pneumatic.Simulation(rig)
    # the rig's ctrl: its valve commands uP and uN, then its chamber actuators P and N
    sim.ctrl = [1.0, 2.0, 0.0, 0.0]
    assert list(sim.ctrl) == [1.0, 2.0, 0.0, 0.0] and sim.command("cyl.uN") == 1
    with pytest.raises(ValueError, match="ctrl takes 4 numbers"):
        sim.ctrl = [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="no cylinder 'knee'"):
        sim.pressure("knee", "P")
    with pytest.raises(ValueError, match="not a command column"):
        sim.command("cyl.u1")


def test_set_pressure_is_absolute(rig):
    sim = pneumatic.Simulation(rig)
    sim.set_pressure("cyl", "N", 3.5e5)
    assert sim.pressure("cyl", "N") == 3.5e5
    assert sim.act[1] == 3.5e5 - rig.get("cyl:p_atm")


def test_pressures_follow_a_changed_p_atm(rig):
    # the activations are p - p_atm: with p_atm set after the simulation was made, the same activation
    # reads as the pressure above the new p_atm
    sim = pneumatic.Simulation(rig)
    sim.set_pressure("cyl", "N", 3e5)
    rig.set("cyl:p_atm", 101325.0)
    assert sim.pressure("cyl", "N") == (3e5 - 1e5) + 101325.0
    assert sim.pressures()[0, 1] == (3e5 - 1e5) + 101325.0
