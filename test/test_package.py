"""The package as users get it: colcon build, the ament layout `ros2 run` relies on, the CLIs."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent
EXECUTABLES = (
    "fbcc-bench",
    "fbcc-maps",
    "fbcc-mapping-study",
    "fbcc-sim",
    "fbcc-montecarlo",
    "fbcc-kinematics",
    "fbcc-calibrate",
    "fbcc-report",
    "fbcc_bringup",
    "dynamic_compensation",
    "kinematics",
    "fbcc_controller",
    "mock_cell",
    "fbcc_record",
    "fbcc_replay",
)


def test_package_xml_is_accepted_by_catkin_pkg() -> None:
    from catkin_pkg.package import parse_package

    pkg = parse_package(str(ROOT / "package.xml"))
    assert pkg.name == "fbcc_ros"
    assert pkg.package_format == 3
    assert pkg.get_build_type() == "ament_python"
    pkg.validate()  # raises on an invalid maintainer e-mail, among others


@pytest.fixture(scope="module")
def colcon_install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    colcon = VENV_BIN / "colcon"
    if not colcon.exists():
        pytest.fail(f"colcon is not installed in {VENV_BIN}: run scripts/bootstrap.sh")
    work = tmp_path_factory.mktemp("colcon")
    src = work / "src" / "fbcc_ros"
    shutil.copytree(
        ROOT,
        src,
        ignore=shutil.ignore_patterns(
            ".venv", ".git", "build", "install", "log", "out", "__pycache__", "*.egg-info"
        ),
    )
    env = {**os.environ, "PATH": f"{VENV_BIN}:{os.environ['PATH']}"}
    listed = subprocess.run(
        [str(colcon), "list"], cwd=work, env=env, capture_output=True, text=True, check=True
    ).stdout
    assert "fbcc_ros" in listed and "(ros.ament_python)" in listed, listed
    build = subprocess.run(
        [str(colcon), "build"], cwd=work, env=env, capture_output=True, text=True
    )
    assert build.returncode == 0, build.stdout + build.stderr
    return work / "install"


def test_colcon_installs_what_ros2_run_looks_up(colcon_install: Path) -> None:
    """`ros2 run fbcc_ros EXE`: package prefix from the ament index, then lib/fbcc_ros/EXE."""
    from ament_index_python.packages import get_package_prefix

    os.environ["AMENT_PREFIX_PATH"] = str(colcon_install / "fbcc_ros")
    prefix = Path(get_package_prefix("fbcc_ros"))
    assert (prefix / "share" / "fbcc_ros" / "package.xml").exists()
    scenarios = {p.name for p in (ROOT / "config" / "scenarios").glob("*.yaml")}
    installed = {p.name for p in (prefix / "share/fbcc_ros/config/scenarios").glob("*.yaml")}
    assert scenarios and installed == scenarios
    for exe in EXECUTABLES:
        path = prefix / "lib" / "fbcc_ros" / exe
        assert path.exists() and os.access(path, os.X_OK), exe
    # what `source install/setup.bash` adds: the workspace's site-packages
    site = next(prefix.glob("lib/python3*/site-packages"))
    env = {**os.environ, "PYTHONPATH": str(site)}
    help_run = subprocess.run(
        [str(prefix / "lib" / "fbcc_ros" / "fbcc-maps"), "--help"],
        capture_output=True,
        text=True,
        env=env,
        cwd="/",
    )
    assert help_run.returncode == 0 and "Fig. 5" in help_run.stdout
    # The iiwa URDF is installed to share/ and travels with the installed code that loads it.
    assert (prefix / "share/fbcc_ros/urdf/iiwa14.urdf").is_file()
    load = subprocess.run(
        [
            str(VENV_BIN / "python"),
            "-c",
            "from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel;"
            "RobotModel.from_name('iiwa14'); print(ROBOTS['iiwa14']().urdf)",
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd="/",
    )
    assert load.returncode == 0, load.stderr
    assert load.stdout.strip().startswith(str(site)), load.stdout


def test_maps_draws_the_figures(tmp_path: Path) -> None:
    from fbcc_ros.cli import maps

    assert maps.main(["--out", str(tmp_path)]) == 0
    for name in ("feature_states.png", "response_states.png", "responses.csv"):
        assert (tmp_path / name).stat().st_size > 1000, name


def test_mapping_study_writes_its_tables(tmp_path: Path) -> None:
    from fbcc_ros.cli import mapping_study

    assert mapping_study.main(["--out", str(tmp_path), "--samples", "200"]) == 0
    assert "| clearance |" in (tmp_path / "mapping_study.md").read_text()
    assert (tmp_path / "mapping_study.png").stat().st_size > 1000


def test_gate_study_writes_its_table_and_figure(tmp_path: Path) -> None:
    """--gate: every case run four ways on one insertion each, read back from the JSON."""
    import json

    from fbcc_ros.cli import mapping_study

    assert mapping_study.main(["--gate", "--out", str(tmp_path), "--trials", "1"]) == 0
    results = json.loads((tmp_path / "gate_study.json").read_text())
    cases = [k for k in results if k != "settings"]
    assert len(cases) == 5  # clearance at three stiffnesses, interference at two
    for case in cases:
        assert [r["trials"] for r in results[case].values()] == [1, 1, 1, 1]
    md = (tmp_path / "gate_study.md").read_text()
    assert "| clearance, k 50 GPa | gated by the truth |" in md
    assert (tmp_path / "gate_study.png").stat().st_size > 10000


def test_state_study_writes_its_tables_and_confusion_matrices(tmp_path: Path) -> None:
    """--estimator: every method of every case scored, its confusion matrix counting each
    scored sample once (read back from the JSON)."""
    import json

    from fbcc_ros.cli import mapping_study

    assert mapping_study.main(["--estimator", "--out", str(tmp_path), "--samples", "100",
                               "--trials", "1", "--placement", "peg_top"]) == 0  # fmt: skip
    results = json.loads((tmp_path / "state_study.json").read_text())
    cases = [k for k in results if k != "settings"]
    assert len(cases) == 12  # per fit: two ways of drawing, three stiffnesses, those pooled
    assert all(", F/T at the wrist |" in case for case in cases)
    for case in cases:
        methods = {m: r for m, r in results[case].items() if isinstance(r, dict)}
        assert len(methods) == 3
        for r in methods.values():
            assert sum(map(sum, r["confusion"])) == r["samples"] > 0
    fit = "interference, F/T at the wrist"
    pooled = results[f"{fit} | insertions, k 0.184 + 0.5 + 1 GPa"]["estimator, history"]
    per_k = [results[f"{fit} | insertions, k {k} GPa"]["estimator, history"]
             for k in ("0.184", "0.5", "1")]  # fmt: skip
    assert pooled["samples"] == sum(r["samples"] for r in per_k)
    assert pooled["insertions"] == 3 and all(r["interval"] is None for r in per_k)  # one each
    lo, hi = pooled["interval"]
    assert lo <= pooled["accuracy"] <= hi
    md = (tmp_path / "state_study.md").read_text()
    assert f"| {fit} | insertions, k 1 GPa | estimator, history |" in md
    assert f"| {fit} | insertions, k 0.184 + 0.5 + 1 GPa | estimator, history |" in md
    assert (tmp_path / "state_study.png").stat().st_size > 10000


def test_cli_rejects_an_output_path_that_is_a_file(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    run = subprocess.run(
        [sys.executable, "-m", "fbcc_ros.cli.maps", "--out", str(blocker / "x")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert run.returncode == 2
    assert "--out" in run.stderr and "Traceback" not in run.stderr


def test_readme_commands_are_what_ci_runs() -> None:
    readme = (ROOT / "README.md").read_text()
    assert "bash scripts/demo.sh" in readme and "bash scripts/test.sh" in readme
    assert "bash scripts/test.sh" in (ROOT / ".ci" / "run").read_text()


def test_readme_scenario_example_validates() -> None:
    import yaml

    from fbcc_ros.core.sim.scenario import validate

    readme = (ROOT / "README.md").read_text()
    block = readme.split("```yaml\n", 1)[1].split("```", 1)[0]
    sc = validate(yaml.safe_load(block))
    assert sc.laws == ("fbcc", "admittance") and sc.geometry.fit == "clearance"


def test_readme_python_examples_run(capsys: pytest.CaptureFixture[str]) -> None:
    readme = (ROOT / "README.md").read_text()
    blocks = [b.split("```", 1)[0] for b in readme.split("```python\n")[1:]]
    assert len(blocks) >= 2
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})  # each example stands alone
    out = capsys.readouterr().out
    assert "('D1', 'P0')" in out


#: What each layer may import of the package (any other fbcc_ros import is an arrow against
#: the layers): the core is ROS-free, the stages build on it, the ROS plumbing on the stages'
#: parameter tables, the bag on the stages and the codec, the nodes on all of these; the
#: studies on the core alone; the harness (a cell run) and the command-line tools sit on top.
LAYERS = {
    "core": {"core"},
    "pipeline": {"core", "pipeline"},
    "ros": {"core", "pipeline", "ros"},
    "bag": {"core", "pipeline", "ros", "bag"},
    "nodes": {"core", "pipeline", "ros", "bag", "harness", "nodes"},
    "studies": {"core", "studies"},
}


def _imports(path: Path) -> set[str]:
    """The fbcc_ros subpackages a module imports, at any depth of its code."""
    import ast

    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        found |= {n.split(".")[1] for n in names if n.startswith("fbcc_ros.") and n.count(".")}
    return found


@pytest.mark.parametrize("layer", LAYERS)
def test_each_layer_imports_only_the_layers_below_it(layer: str) -> None:
    wrong = {str(path.relative_to(ROOT)): sorted(_imports(path) - LAYERS[layer])
             for path in sorted((ROOT / "fbcc_ros" / layer).rglob("*.py"))}  # fmt: skip
    assert not {k: v for k, v in wrong.items() if v}, wrong


#: The longest a module of the package may be [lines]: one concept a module.
MODULE_LINES = 400


def test_no_module_of_the_package_is_over_400_lines() -> None:
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / "fbcc_ros").rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MODULE_LINES}  # fmt: skip
    assert not long, long


def test_the_tests_mirror_the_package_layout() -> None:
    """Each test folder is named for the package folder whose modules it tests."""
    folders = [p for p in (ROOT / "test").rglob("*") if p.is_dir()
               and not {"__pycache__", "data"} & set(p.relative_to(ROOT).parts)]  # fmt: skip
    strays = [str(p.relative_to(ROOT)) for p in folders
              if not (ROOT / "fbcc_ros" / p.relative_to(ROOT / "test")).is_dir()]  # fmt: skip
    assert not strays, strays
