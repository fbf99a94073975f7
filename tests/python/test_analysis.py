# pneumatic.identify and pneumatic.diagnose against `pneumo identify` and `pneumo diagnose`: the same
# documents, as Python objects, on logs `pneumo generate` makes of the rig (paper 000's identification
# experiment, with the generator's sensor noise).
import json
import math

import pytest

import pneumatic


@pytest.fixture(scope="module")
def logs(models, pneumo, tmp_path_factory):
    folder = tmp_path_factory.mktemp("analysis")
    paths = {}
    for name, seed, duration in (("train", 1, 3), ("heldout", 2, 3)):
        paths[name] = str(folder / (name + ".csv"))
        pneumo("generate", models / "rig_per_chamber.xml", "--duration", duration, "--seed", seed, "--out", paths[name])
    paths["folder"] = folder
    return paths


def same(a, b, path="document"):
    """JSON documents equal, NaN standing for null (JSON has no NaN) and timings aside."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for key in a:
            if key not in ("seconds", "wall_s"):
                same(a[key], b[key], path + "." + key)
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, "%s[%d]" % (path, i))
    elif isinstance(a, float) and math.isnan(a):
        assert b is None or math.isnan(b), path
    else:
        assert a == b, path


def test_identify_returns_the_document_the_cli_writes(models, logs, pneumo):
    rig = str(models / "rig_per_chamber.xml")
    out = logs["folder"] / "params.json"
    pneumo("identify", rig, logs["train"], "--heldout", logs["heldout"], "--skip-physical", "--out", out)
    document = pneumatic.identify(rig, logs["train"], heldout=logs["heldout"], physical=False)
    same(document, json.loads(out.read_text()))
    assert len(document["chambers"]["cyl.P"]["c"]) == 9


def test_identify_refuses_its_inputs_with_value_error(models, logs):
    with pytest.raises(ValueError, match="nothing to fit"):
        pneumatic.identify(str(models / "rig_per_chamber.xml"), logs["train"], parametric=False, physical=False)
    with pytest.raises(ValueError, match="missing.csv"):
        pneumatic.identify(str(models / "rig_per_chamber.xml"), str(logs["folder"] / "missing.csv"))


def test_diagnose_returns_the_json_the_cli_prints(models, logs, pneumo):
    rig = str(models / "rig_per_chamber.xml")
    printed = pneumo("diagnose", rig, logs["train"], "--heldout", logs["heldout"], "--max-effects", 1,
                     "--calibration-iterations", 0, "--quiet").stdout
    messages = []
    document = pneumatic.diagnose(rig, logs["train"], heldout=logs["heldout"], max_effects=1,
                                  calibration_iterations=0, progress=messages.append)
    same(document, json.loads(printed))
    assert document["verdict"]["effect"] in ("none", "unexplained") or document["verdict"]["effects"]
    assert messages  # the progress lines reached Python
