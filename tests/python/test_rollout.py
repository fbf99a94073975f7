# pneumatic.rollout against `pneumo rollout`: the same options give the same log, byte for byte through
# the same writer, and the same summary; errors are ValueError with the library's message.
import json
import threading

import numpy as np
import pytest

import pneumatic


@pytest.fixture
def rig_path(models):
    return str(models / "rig_per_chamber.xml")


@pytest.fixture
def reference(tmp_path):
    """A 1 s reference for the rig's piston: a 2 Hz sine of 30 mm about mid-stroke."""
    t = np.arange(0, 1.0 + 1e-9, 0.01)
    path = str(tmp_path / "ref.csv")
    pneumatic.write_log(path, {"time": t, "cyl.ref": 0.03 * np.sin(2 * np.pi * 2 * t)})
    return path


def same_bytes(a, b):
    with open(a, "rb") as fa, open(b, "rb") as fb:
        return fa.read() == fb.read()


def test_open_loop_constant_commands_same_bytes_as_the_cli(rig_path, pneumo, tmp_path):
    pneumo("rollout", rig_path, "--duration", 0.5, "--set", "cyl.uP=7", "--set", "cyl.uN=3",
           "--out", tmp_path / "cli.csv")
    result = pneumatic.rollout(pneumatic.load(rig_path), duration=0.5, set={"cyl.uP": 7, "cyl.uN": 3})
    assert list(result)[:2] == ["time", "cyl.uP"]
    assert result["time"].shape == (500,)
    pneumatic.write_log(str(tmp_path / "py.csv"), result)
    assert same_bytes(tmp_path / "cli.csv", tmp_path / "py.csv")
    # and read back, the CLI's log holds exactly the numbers returned
    read = pneumatic.read_log(str(tmp_path / "cli.csv"))
    for column in result:
        if column != "comments":
            assert np.array_equal(read[column], result[column]), column


def test_closed_loop_same_log_and_summary_as_the_cli(rig_path, reference, pneumo, tmp_path):
    pneumo("rollout", rig_path, "--controller", "pid", "--reference", reference, "--duration", 0.6, "--seed", 3,
           "--noise-pressure", 500, "--noise-position", 1e-4, "--out", tmp_path / "cli.csv",
           "--summary", tmp_path / "cli.json")
    result = pneumatic.rollout(rig_path, controller="pid", reference=reference, duration=0.6, seed=3,
                               noise_pressure=500, noise_position=1e-4)
    pneumatic.write_log(str(tmp_path / "py.csv"), result)
    assert same_bytes(tmp_path / "cli.csv", tmp_path / "py.csv")
    cli = json.loads((tmp_path / "cli.json").read_text())
    summary = result["summary"]
    # everything but the wall-clock time and what it gives
    for timing in ("wall_s", "real_time_factor"):
        cli.pop(timing), summary.pop(timing)
    assert summary == cli
    assert summary["run"] == "seed3" and summary["controller"]["name"] == "pid"


def test_open_loop_replay_of_a_log_file_and_of_an_array_agree_with_the_cli(rig_path, reference, pneumo, tmp_path):
    closed = pneumatic.rollout(rig_path, controller="pid", reference=reference)  # the reference's 1 s
    assert closed["time"][-1] == pytest.approx(0.99)
    commands = str(tmp_path / "commands.csv")
    pneumatic.write_log(commands, closed)
    pneumo("rollout", rig_path, "--commands", commands, "--out", tmp_path / "cli.csv")
    model = pneumatic.load(rig_path)
    from_file = pneumatic.rollout(model, commands)
    pneumatic.write_log(str(tmp_path / "py.csv"), from_file)
    assert same_bytes(tmp_path / "cli.csv", tmp_path / "py.csv")
    # the same commands as an array: the same simulated columns (only the comments name no file)
    table = np.column_stack([closed["time"], closed["cyl.uP"], closed["cyl.uN"], closed["cyl.p_P"], closed["cyl.p_N"],
                             closed["cyl.x"], closed["cyl.v"]])
    from_array = pneumatic.rollout(model, table, columns=["cyl.uP", "cyl.uN", "cyl.p_P", "cyl.p_N", "cyl.x", "cyl.v"])
    for column in ("time", "cyl.p_P", "cyl.p_N", "cyl.x", "cyl.v", "cyl.p_S"):
        assert np.array_equal(from_array[column], from_file[column]), column
    assert from_file["comments"][1] == "commands: " + commands


def test_a_controller_configuration_as_a_dict_or_a_file_gives_the_same_run(rig_path, reference, tmp_path):
    gains = {"kp": 2.0, "ki": 0.5}
    (tmp_path / "gains.json").write_text(json.dumps(gains))
    by_dict = pneumatic.rollout(rig_path, controller="pid", controller_config=gains, reference=reference, duration=0.3)
    by_file = pneumatic.rollout(rig_path, controller="pid", controller_config=str(tmp_path / "gains.json"),
                                reference=reference, duration=0.3)
    assert np.array_equal(by_dict["cyl.uP"], by_file["cyl.uP"])
    assert by_dict["summary"]["controller"]["configuration"] == "controller_config"
    default = pneumatic.rollout(rig_path, controller="pid", reference=reference, duration=0.3)
    assert not np.array_equal(default["cyl.uP"], by_dict["cyl.uP"])


def test_refusals_are_value_errors_with_the_message(rig_path, reference, tmp_path):
    with pytest.raises(ValueError, match="does not take commands"):
        pneumatic.rollout(rig_path, str(tmp_path / "x.csv"), controller="pid", duration=1)
    with pytest.raises(ValueError, match="needs a duration"):
        pneumatic.rollout(rig_path, controller="pid")
    with pytest.raises(ValueError, match="reference needs a controller"):
        pneumatic.rollout(rig_path, reference=reference, duration=1)
    with pytest.raises(ValueError, match="missing.csv"):
        pneumatic.rollout(rig_path, str(tmp_path / "missing.csv"))
    with pytest.raises(ValueError, match="kp"):
        pneumatic.rollout(rig_path, controller="pid", controller_config={"kp": "high"}, duration=0.1)
    with pytest.raises(ValueError, match="no cylinder 'knee'"):
        pneumatic.rollout(rig_path, {"time": [0.0, 0.001], "knee.uP": [1.0, 1.0]})


def test_rollouts_in_two_threads_equal_the_same_rollouts_one_after_the_other(models, reference):
    # each thread runs without the GIL; the runs are independent, so their logs are those of serial runs
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    seeds = [1, 2, 3, 4]
    serial = [pneumatic.rollout(model, controller="pid", reference=reference, seed=s, noise_pressure=300) for s in seeds]
    parallel = [None] * len(seeds)

    def run(i):
        parallel[i] = pneumatic.rollout(model, controller="pid", reference=reference, seed=seeds[i], noise_pressure=300)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(seeds))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(serial, parallel):
        for column in a:
            if column not in ("comments", "summary"):
                assert np.array_equal(a[column], b[column]), column


def test_stepping_in_two_threads_equals_stepping_serially(models):
    model = pneumatic.load(str(models / "rig_per_chamber.xml"))
    sims = [pneumatic.Simulation(model) for _ in range(4)]
    for i, sim in enumerate(sims):
        sim.ctrl[[sim.command("cyl.uP"), sim.command("cyl.uN")]] = [2.0 + i, 8.0 - i]
    serial = [pneumatic.Simulation(model) for _ in range(4)]
    for i, sim in enumerate(serial):
        sim.ctrl[[sim.command("cyl.uP"), sim.command("cyl.uN")]] = [2.0 + i, 8.0 - i]
        sim.step(2000)
    threads = [threading.Thread(target=sim.step, args=(2000,)) for sim in sims]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(sims, serial):
        assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.act, b.act)
