"""Offscreen pictures of hand postures with MuJoCo's renderer, on a headless machine.

MuJoCo picks its OpenGL backend when it is first imported, so the pictures are made in a child
process with MUJOCO_GL set explicitly (EGL first, then OSMesa). Where neither works,
`RenderingUnavailable` says what to install.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

BACKENDS = ("egl", "osmesa")
HOW_TO_ENABLE = ("install an offscreen OpenGL driver (Debian/Ubuntu: apt-get install libegl1 libgl1 "
                 "libegl-mesa0 libosmesa6) so that MUJOCO_GL=egl or MUJOCO_GL=osmesa works")


class RenderingUnavailable(RuntimeError):
    """No offscreen OpenGL context could be created."""


def render_postures(postures: np.ndarray, size: int = 160, backends: tuple[str, ...] | None = None) -> np.ndarray:
    """Images (n, size, size, 3) uint8 of the hand in each posture (n, 22), on a white background."""
    postures = np.asarray(postures, dtype=float).reshape(-1, 22)
    errors = []
    with tempfile.TemporaryDirectory() as tmp:
        source, target = Path(tmp) / "postures.npy", Path(tmp) / "images.npy"
        np.save(source, postures)
        for backend in backends or BACKENDS:
            env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
            run = subprocess.run([sys.executable, "-m", "graspmanifold.render", str(source), str(target), str(size)],
                                 env=env, capture_output=True, text=True)
            if run.returncode == 0 and target.exists():
                return np.load(target)
            errors.append(f"{backend}: {(run.stderr or run.stdout).strip().splitlines()[-1:] or ['failed']}")
    raise RenderingUnavailable(f"no offscreen OpenGL context ({'; '.join(errors)}); to enable, {HOW_TO_ENABLE}")


def _render_in_this_process(postures: np.ndarray, size: int) -> np.ndarray:
    import mujoco

    from .hand import load_hand
    from .posture import posture_to_ctrl

    model = load_hand()
    for name in ("forearm", "wrist"):  # the palm and fingers are the subject
        model.geom_rgba[model.geom(name).id, 3] = 0.0
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, size)
    model.vis.global_.offheight = max(model.vis.global_.offheight, size)
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, size, size)
    finger_qpos = model.jnt_qposadr[2:]
    mujoco.mj_forward(model, data)
    palm = model.body("palm").id
    rotation = data.xmat[palm].reshape(3, 3)
    lookat = data.xpos[palm] + rotation @ np.array([0.0, -0.02, 0.085])
    eye = lookat + rotation @ np.array([0.13, -0.2, 0.02])
    forward = (lookat - eye) / np.linalg.norm(lookat - eye)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = lookat
    camera.distance = float(np.linalg.norm(lookat - eye))
    camera.azimuth = float(np.degrees(np.arctan2(forward[1], forward[0])))
    camera.elevation = float(np.degrees(np.arcsin(forward[2])))
    images = np.empty((len(postures), size, size, 3), dtype=np.uint8)
    for i, posture in enumerate(postures):
        data.qpos[finger_qpos] = posture
        data.ctrl[:] = posture_to_ctrl(posture)
        mujoco.mj_kinematics(model, data)
        renderer.update_scene(data, camera)
        image = renderer.render()
        image[image.max(axis=2) < 6] = 255  # a white background instead of the empty black scene
        images[i] = image
    renderer.close()
    return images


if __name__ == "__main__":
    source, target, pixels = sys.argv[1], sys.argv[2], int(sys.argv[3])
    np.save(target, _render_in_this_process(np.load(source), pixels))
