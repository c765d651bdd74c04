"""fbcc-report on the committed session bag: the figures, the summary, and bad input."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.cli import report

ROOT = Path(__file__).resolve().parents[2]
BAG = ROOT / "test" / "data" / "bags" / "short_interference"


def test_the_report_of_a_recorded_session(tmp_path: Path, capsys) -> None:
    assert report.main([str(BAG), "--out", str(tmp_path)]) == 0
    assert "inserted" in capsys.readouterr().out
    for name in ("trajectories.png", "planes.png", "states.png", "estimate.png",
                 "contact_states.png"):
        assert (tmp_path / name).stat().st_size > 20_000, name
    summary = json.loads((tmp_path / "summary.json").read_text())
    bag = read_bag(BAG)
    assert summary["messages"] == {t: bag.counts[t] for t in bag.topics}
    assert summary["truncated"] == "" and summary["commands"] == bag.counts["/fbcc/command"]
    assert [p["phase"] for p in summary["phases"]] == ["idle", "armed", "inserting", "inserted"]
    # the scenario's 4 mm at 5 mm/s from the first command (the robust law slows or holds the
    # depth while the lateral loops settle), within the 1.6 s session; counted in control
    # periods, at least one per sample: the mock's jittered stamps (two 64 µs apart in this
    # session) add periods, 5.1-5.2 mm/s of stamp time here, so 5 % faster at most
    assert 0.8 / 1.05 <= summary["insertion_time_s"] <= 1.6
    # the depth ends at 4 mm along the peg's own axis (the axis depth): the features' l, in
    # this untilted hole, differs by at most 2 r |theta| of the peg's residual tilt
    final = summary["final_features"]
    tilt = math.hypot(final["theta_x"], final["theta_y"])
    assert abs(final["l"] - 4e-3) <= 2 * 5.04e-3 * tilt + 1e-7 and tilt < 1e-3, final
    # the robust law's identification, recorded and reported: positive, bounded stiffnesses
    est = summary["contact_estimate"]
    assert est["k_dx"] > 0 and est["k_theta_y"] > 0 and 0 < est["friction"] < 1
    for plane in ("XOZ", "YOZ"):
        assert sum(summary["contact_state_share"][plane].values()) == pytest.approx(1.0, abs=1e-3)
    # the peak axial force is the one the mock's truth had, seen through the compensation
    truth_fz = max(np.frombuffer(m.data[-40:], "<f8")[2] for m in bag.of("/mock_cell/truth"))
    assert summary["peak_fz_n"] == pytest.approx(truth_fz, rel=0.05)
    text = (tmp_path / "summary.md").read_text()
    assert "final phase **inserted**" in text and "truncated" not in text
    # the contact state along the session: the deviation filter, run at every 5th sample (200
    # updates a second of a 1 kHz cell) from the first contact, within the session's first
    # tenth, names the mock's true state more often than boundary mapping does, in both planes
    states = summary["contact_state_estimate"]
    assert states["every_nth_sample"] == 5
    assert 0.9 * summary["commands"] / 5 <= states["updates"] <= summary["commands"] / 5 + 1
    agree = states["agreement_with_truth"]
    for plane in ("XOZ", "YOZ"):
        assert agree["deviation filter"][plane] > agree["boundary mapping"][plane] + 0.1, agree
    assert states["source"] == "deviation filter, run by the report"  # the bag has none of its own
    assert "![contact states](contact_states.png)" in text
    said = f"deviation filter: the mock's true state XOZ {agree['deviation filter']['XOZ']:.0%}"
    assert said in text


def _estimate_bag(folder: Path, rows: list[list[float]], layout: list[tuple[str, int, int]]):
    from fbcc_ros.bag.writer import BagWriter
    from fbcc_ros.ros.cdr import encode_array

    with BagWriter(folder) as writer:
        writer.add_topic("/fbcc/contact_estimate", "std_msgs/msg/Float64MultiArray", [])
        for row in rows:
            writer.write("/fbcc/contact_estimate", encode_array(row, layout), int(row[0] * 1e9))
    return read_bag(folder)


def test_the_estimate_is_read_by_the_labels_it_was_recorded_with(tmp_path: Path) -> None:
    """The controller labels fbcc/contact_estimate's one dimension with its fields; the report
    names the columns by that label, so a bag recorded before a field existed (one without
    lever_friction) reads right, and a label that does not match the data is refused, not read
    shifted."""
    from fbcc_ros.core.control.identification import ESTIMATE_FIELDS, ContactEstimate
    from fbcc_ros.core.errors import InputError
    from fbcc_ros.nodes.fbcc_controller import ESTIMATE_LAYOUT

    est = ContactEstimate(np.arange(1.0, 5.0), np.zeros(4), np.full(4, 5.0), np.full(4, 6.0),
                          0.41, 0.27, True)  # fmt: skip
    rows = [[t, *est.as_row(trips=2)] for t in (10.0, 10.5)]
    t, cols = report.contact_estimate(_estimate_bag(tmp_path / "now", rows, ESTIMATE_LAYOUT), 10.0)
    assert t.tolist() == [0.0, 0.5] and list(cols) == list(ESTIMATE_FIELDS)
    assert cols["lever_friction"].tolist() == [0.27, 0.27] and cols["friction"][0] == 0.41
    assert cols["k_theta_y"][0] == 4.0 and cols["guard_trips"][0] == 2.0
    before = ("stamp", *(f for f in ESTIMATE_FIELDS if f != "lever_friction"))
    dropped = ESTIMATE_FIELDS.index("lever_friction") + 1
    old_rows = [row[:dropped] + row[dropped + 1:] for row in rows]
    old_layout = [(" ".join(before), len(before), len(before))]
    _, old = report.contact_estimate(_estimate_bag(tmp_path / "old", old_rows, old_layout), 10.0)
    assert "lever_friction" not in old and set(old) == set(ESTIMATE_FIELDS) - {"lever_friction"}
    assert old["in_contact"].tolist() == [1.0, 1.0] and old["guard_trips"].tolist() == [2.0, 2.0]
    assert old["friction"][0] == 0.41
    short = [(ESTIMATE_LAYOUT[0][0].rsplit(" ", 1)[0], len(rows[0]), len(rows[0]))]
    with pytest.raises(InputError, match="contact_estimate"):
        report.contact_estimate(_estimate_bag(tmp_path / "shifted", rows, short), 10.0)


def test_a_cut_bag_is_reported_as_truncated(tmp_path: Path, capfd) -> None:
    cut = tmp_path / "cut"
    cut.mkdir()
    whole = BAG / "short_interference_0.mcap"
    data = whole.read_bytes()
    (cut / whole.name).write_bytes(data[: int(len(data) * 0.7)])
    shutil.copy(BAG / "fbcc_params.yaml", cut)
    assert report.main([str(cut), "--out", str(tmp_path / "r")]) == 0
    assert "NOT WHOLE" in capfd.readouterr().err
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["truncated"] and 0 < summary["commands"] < read_bag(BAG).counts["/fbcc/command"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["no/such/bag"], "an existing .mcap file or bag folder"),
        (["{junk}"], "an mcap file"),
        (["{no_features}"], "messages on /fbcc/features"),
        ([str(BAG), "--scenario", "no/such.yaml"], "no/such.yaml"),
    ],
)
def test_bad_input_is_one_line_and_exit_two(args, message, tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCA not really")
    from fbcc_ros.bag.writer import BagWriter

    with BagWriter(tmp_path / "no_features") as bag:  # a bag of something else
        bag.add_topic("/chatter", "std_msgs/msg/String", [])
    args = [a.format(junk=junk, no_features=tmp_path / "no_features") for a in args]
    proc = subprocess.run([sys.executable, "-m", "fbcc_ros.cli.report", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert message in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
