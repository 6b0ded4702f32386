"""The Kalibr and OpenVINS files name the IMU topic they describe: the bag's, or
--topic's when the bag holds several (bags written with rosbags, as users' are)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from test_formats import imu, write_ros1  # noqa: F401  (imu: the fixture of the sensor's values)


def _rostopic(path: Path) -> str:
    lines = [ln.split("#")[0].strip() for ln in path.read_text().splitlines()]
    return next(ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("rostopic:"))


def test_the_files_name_the_bags_topic(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:  # noqa: F811
    bag = write_ros1(tmp_path / "one.bag", imu, {"/sensors/imu": "imu_link"})
    k, o = tmp_path / "k.yaml", tmp_path / "o.yaml"
    rc, _, err = run_cli("analyze", bag, "--no-model", "--no-warmup", "--json", "--kalibr", k, "--openvins", o)
    assert rc == 0, err
    assert _rostopic(k) == _rostopic(o) == "/sensors/imu"


def test_topic_chosen_among_several_is_the_one_named(imu: dict[str, Any], tmp_path: Path, run_cli) -> None:  # noqa: F811
    bag = write_ros1(tmp_path / "two.bag", imu, {"/imu0": "a", "/imu1": "b"})
    k = tmp_path / "k.yaml"
    rc, _, err = run_cli("analyze", bag, "--topic", "/imu1", "--no-model", "--no-warmup", "--json", "--kalibr", k)
    assert rc == 0, err
    assert _rostopic(k) == "/imu1"
