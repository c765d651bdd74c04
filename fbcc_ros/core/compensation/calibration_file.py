"""The payload calibration's file: the parameter YAML ``fbcc-calibrate`` writes and the
``dynamic_compensation`` node loads (its ``payload`` and ``bias``, under any namespace)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.payload import Calibration, Payload
from fbcc_ros.core.errors import ConfigError, require_vector
from fbcc_ros.core.files import read_yaml
from fbcc_ros.core.param_files import node_section

#: Node name whose parameters the calibration YAML holds.
NODE_NAME = "dynamic_compensation"


def calibration_yaml(fit: Calibration, comment: str) -> str:
    """The parameter file the ``dynamic_compensation`` node loads, with the fit's quality in a
    comment header."""
    params = {
        f"/**/{NODE_NAME}": {  # any namespace: the node under /lbr reads it too
            "ros__parameters": {
                "payload": {
                    "mass": float(fit.payload.mass),
                    "com": [float(x) for x in fit.payload.com],
                    "inertia": [float(x) for row in fit.payload.inertia for x in row],
                },
                "bias": [float(x) for x in fit.bias],
            }
        }
    }
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    return header + yaml.safe_dump(params, sort_keys=False, default_flow_style=None)


def load_calibration(path: str | Path) -> tuple[Payload, FloatArray]:
    """Payload and bias from a file :func:`calibration_yaml` wrote (or a node parameter file
    with the same keys)."""
    try:
        data: Any = read_yaml(path, "calibration file")
        params = node_section(data, NODE_NAME)
        if params is None:
            raise KeyError(NODE_NAME)
        payload = params["payload"]
        inertia = np.asarray(payload.get("inertia", [0.0] * 9), dtype=float).reshape(3, 3)
        return (
            Payload(
                float(payload["mass"]),
                tuple(float(x) for x in payload["com"]),  # type: ignore[arg-type]
                tuple(map(tuple, inertia.tolist())),
            ),
            require_vector("bias", params["bias"], 6),
        )
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(
            "calibration",
            str(path),
            f"a YAML file with {NODE_NAME}.ros__parameters.payload.(mass, com, inertia) and .bias"
            f" ({type(exc).__name__}: {exc})",
        ) from exc
