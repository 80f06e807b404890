"""The kinematics sheet (shared/reference/shadow_hand_kinematics.md) as test data, and an
independent forward-kinematics implementation over it, to check the MJCF against."""

from __future__ import annotations

import numpy as np

# body: (parent, pos, quat wxyz, joint, axis, range)
SHEET = {
    "ffknuckle": ("palm", (0.033, 0, 0.095), (1, 0, 0, 0), "FFJ4", (0, -1, 0), (-0.349066, 0.349066)),
    "ffproximal": ("ffknuckle", (0, 0, 0), (1, 0, 0, 0), "FFJ3", (1, 0, 0), (-0.261799, 1.5708)),
    "ffmiddle": ("ffproximal", (0, 0, 0.045), (1, 0, 0, 0), "FFJ2", (1, 0, 0), (0, 1.5708)),
    "ffdistal": ("ffmiddle", (0, 0, 0.025), (1, 0, 0, 0), "FFJ1", (1, 0, 0), (0, 1.5708)),
    "mfknuckle": ("palm", (0.011, 0, 0.099), (1, 0, 0, 0), "MFJ4", (0, -1, 0), (-0.349066, 0.349066)),
    "mfproximal": ("mfknuckle", (0, 0, 0), (1, 0, 0, 0), "MFJ3", (1, 0, 0), (-0.261799, 1.5708)),
    "mfmiddle": ("mfproximal", (0, 0, 0.045), (1, 0, 0, 0), "MFJ2", (1, 0, 0), (0, 1.5708)),
    "mfdistal": ("mfmiddle", (0, 0, 0.025), (1, 0, 0, 0), "MFJ1", (1, 0, 0), (0, 1.5708)),
    "rfknuckle": ("palm", (-0.011, 0, 0.095), (1, 0, 0, 0), "RFJ4", (0, 1, 0), (-0.349066, 0.349066)),
    "rfproximal": ("rfknuckle", (0, 0, 0), (1, 0, 0, 0), "RFJ3", (1, 0, 0), (-0.261799, 1.5708)),
    "rfmiddle": ("rfproximal", (0, 0, 0.045), (1, 0, 0, 0), "RFJ2", (1, 0, 0), (0, 1.5708)),
    "rfdistal": ("rfmiddle", (0, 0, 0.025), (1, 0, 0, 0), "RFJ1", (1, 0, 0), (0, 1.5708)),
    "lfmetacarpal": ("palm", (-0.033, 0, 0.02071), (1, 0, 0, 0), "LFJ5", (0.573576, 0, 0.819152), (0, 0.785398)),
    "lfknuckle": ("lfmetacarpal", (0, 0, 0.06579), (1, 0, 0, 0), "LFJ4", (0, 1, 0), (-0.349066, 0.349066)),
    "lfproximal": ("lfknuckle", (0, 0, 0), (1, 0, 0, 0), "LFJ3", (1, 0, 0), (-0.261799, 1.5708)),
    "lfmiddle": ("lfproximal", (0, 0, 0.045), (1, 0, 0, 0), "LFJ2", (1, 0, 0), (0, 1.5708)),
    "lfdistal": ("lfmiddle", (0, 0, 0.025), (1, 0, 0, 0), "LFJ1", (1, 0, 0), (0, 1.5708)),
    "thbase": ("palm", (0.034, -0.00858, 0.029), (0.92388, 0, 0.382683, 0), "THJ5", (0, 0, -1), (-1.0472, 1.0472)),
    "thproximal": ("thbase", (0, 0, 0), (1, 0, 0, 0), "THJ4", (1, 0, 0), (0, 1.22173)),
    "thhub": ("thproximal", (0, 0, 0.038), (1, 0, 0, 0), "THJ3", (1, 0, 0), (-0.20944, 0.20944)),
    "thmiddle": ("thhub", (0, 0, 0), (1, 0, 0, 0), "THJ2", (0, -1, 0), (-0.698132, 0.698132)),
    "thdistal": ("thmiddle", (0, 0, 0.032), (1, 0, 0, -1), "THJ1", (1, 0, 0), (-0.261799, 1.5708)),
}
WRIST_RANGES = {"WRJ2": (-0.523599, 0.174533), "WRJ1": (-0.698132, 0.488692)}
TIPS = {"fftip": ("ffdistal", 0.026), "mftip": ("mfdistal", 0.026), "rftip": ("rfdistal", 0.026),
        "lftip": ("lfdistal", 0.026), "thtip": ("thdistal", 0.0275)}


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _axis_angle(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def sheet_fk(joints: dict[str, float]) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Body origins (= joint positions) and fingertip positions in the palm frame."""
    frames = {"palm": (np.zeros(3), np.eye(3))}
    for body, (parent, pos, quat, joint, axis, _) in SHEET.items():  # parents come first
        p_pos, p_rot = frames[parent]
        rot = p_rot @ _quat_matrix(quat) @ _axis_angle(axis, joints[joint])
        frames[body] = (p_pos + p_rot @ np.asarray(pos, float), rot)
    origins = {body: frames[body][0] for body in SHEET}
    tips = {site: frames[body][0] + frames[body][1] @ np.array([0, 0, length])
            for site, (body, length) in TIPS.items()}
    return origins, tips
