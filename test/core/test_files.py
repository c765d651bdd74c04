"""The user's files are read strictly (fbcc_ros.core.files): a key given twice is refused with
its lines, only a regular file of a sane size is read, and each refusal names the file."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.files import MAX_BYTES, read_text, read_yaml


def test_a_key_given_twice_is_refused_with_both_lines(tmp_path: Path) -> None:
    path = tmp_path / "twice.yaml"
    path.write_text("insertion:\n  depth: 0.01\n  speed: 0.005\n  speed: 0.05\n")
    with pytest.raises(ConfigError, match=r"'speed' given twice, on line 3 and line 4"):
        read_yaml(path, "scenario file")
    path.write_text("geometry: {a: 1}\nname: x\ngeometry: {a: 2}\n")  # a block replaced
    with pytest.raises(ConfigError, match=r"'geometry' given twice, on line 1 and line 3"):
        read_yaml(path, "scenario file")
    # the same key in two mappings is two keys; 5e-5 is a float (YAML 1.2)
    path.write_text("a: {speed: 1}\nb: {speed: 5e-5}\n")
    assert read_yaml(path, "f") == {"a": {"speed": 1}, "b": {"speed": 5e-5}}


def test_a_fifo_is_refused_without_being_opened(tmp_path: Path) -> None:
    fifo = tmp_path / "scenario.yaml"
    os.mkfifo(fifo)
    done: list[BaseException] = []
    reader = threading.Thread(target=lambda: _catch(done, fifo), daemon=True)
    reader.start()
    reader.join(5.0)  # opening a FIFO with no writer would block for good
    assert not reader.is_alive() and "this is a FIFO" in str(done[0])


def _catch(done: list[BaseException], path: Path) -> None:
    try:
        read_text(path, "scenario file")
    except ConfigError as exc:
        done.append(exc)


@pytest.mark.parametrize(("path", "kind"), [("/dev/zero", "a character device"),
                                            ("/", "a folder")])  # fmt: skip
def test_a_device_or_a_folder_is_refused(path: str, kind: str) -> None:
    with pytest.raises(ConfigError, match=f"a regular file \\(this is {kind}\\)"):
        read_text(path, "scenario file")


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    big.write_text("#" * (MAX_BYTES + 1))
    with pytest.raises(ConfigError, match="at most 1024 KiB"):
        read_text(big, "scenario file")
    big.write_text("a: 1\n" + "#" * (MAX_BYTES - 10))
    assert read_yaml(big, "scenario file") == {"a": 1}  # just under: read


def test_a_missing_file_says_so(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"--params-file=.* a readable file \(No such file"):
        read_yaml(tmp_path / "nope.yaml", "--params-file")
