"""Offscreen pictures of hand postures and of scenes with MuJoCo's renderer, on a headless machine,
and animations of them (GIF, through Pillow).

MuJoCo picks its OpenGL backend when it is first imported, so the pictures are made in a child
process with MUJOCO_GL set explicitly (EGL first, then OSMesa). Where neither works,
`RenderingUnavailable` says what to install.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .validation import check_int

if TYPE_CHECKING:
    from .scene import Scene

BACKENDS = ("egl", "osmesa")
#: a view for `render_states` besides a scene's named cameras: from the palm's thumb side, as the
#: hand pictures of the figures are drawn
THUMB_SIDE = "thumb_side"
HOW_TO_ENABLE = ("install an offscreen OpenGL driver (Debian/Ubuntu: apt-get install libegl1 libgl1 "
                 "libegl-mesa0 libosmesa6) so that MUJOCO_GL=egl or MUJOCO_GL=osmesa works")


class RenderingUnavailable(RuntimeError):
    """No offscreen OpenGL context could be created."""


def _in_child(job: dict[str, np.ndarray], backends: tuple[str, ...] | None) -> np.ndarray:
    """Run a drawing job in a child process with each offscreen backend in turn; its images."""
    errors = []
    with tempfile.TemporaryDirectory() as tmp:
        source, target = Path(tmp) / "job.npz", Path(tmp) / "images.npy"
        np.savez(source, **job)
        for backend in backends or BACKENDS:
            env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
            run = subprocess.run([sys.executable, "-m", "graspmanifold.render", str(source), str(target)],
                                 env=env, capture_output=True, text=True)
            if run.returncode == 0 and target.exists():
                return np.load(target)
            errors.append(f"{backend}: {(run.stderr or run.stdout).strip().splitlines()[-1:] or ['failed']}")
    raise RenderingUnavailable(f"no offscreen OpenGL context ({'; '.join(errors)}); to enable, {HOW_TO_ENABLE}")


def render_postures(postures: np.ndarray, size: int = 160, backends: tuple[str, ...] | None = None) -> np.ndarray:
    """Images (n, size, size, 3) uint8 of the hand in each posture (n, 22), on a white background."""
    postures = np.asarray(postures, dtype=float).reshape(-1, 22)
    return _in_child({"kind": np.array("postures"), "postures": postures, "size": np.array(int(size))}, backends)


def render_states(scene: Scene, states: np.ndarray, camera: str = "hand", width: int = 320, height: int = 240,
                  backends: tuple[str, ...] | None = None) -> np.ndarray:
    """Images (k, height, width, 3) uint8 of a scene in each of k states (`Scene.state()`), from
    one of its named cameras (`scene.CAMERAS`) or from the palm's thumb side (`THUMB_SIDE`)."""
    cameras = tuple(scene.model.camera(i).name for i in range(scene.model.ncam)) + (THUMB_SIDE,)
    if camera not in cameras:
        raise ValueError(f"unknown camera {camera!r}; expected one of {cameras}")
    for name, value in (("width", width), ("height", height)):
        check_int(value, f"{name} (pixels)", low=16, high=4096)
    states = np.asarray(states, dtype=float)
    if states.ndim != 2 or states.shape[1] != len(scene.state()) or not np.all(np.isfinite(states)):
        raise ValueError(f"states must be finite with shape (k, {len(scene.state())}) (Scene.state()), "
                         f"got {states.shape}")
    return _in_child({"kind": np.array("scene"), "xml": np.array(scene.spec.to_xml()), "states": states,
                      "camera": np.array(camera), "width": np.array(int(width)), "height": np.array(int(height))},
                     backends)


def png_bytes(image: np.ndarray) -> bytes:
    """An RGB image (h, w, 3) uint8 as PNG bytes."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def save_animation(frames: np.ndarray, path: str | os.PathLike, fps: float = 25.0) -> Path:
    """Write frames (k, h, w, 3) uint8 as an animated GIF that loops (Pillow), atomically."""
    from PIL import Image

    from .io import atomic_write

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or not len(frames):
        raise ValueError(f"frames must have shape (k, height, width, 3) with k >= 1, got {frames.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps!r}")
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"path must end in .gif, got {str(path)!r}")
    images = [Image.fromarray(frame.astype(np.uint8)) for frame in frames]
    with atomic_write(path) as handle:
        images[0].save(handle, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    return path


def _thumb_side_camera(model, data, distance: float = 1.0):
    """A free camera on the palm's thumb side, level with the fingers: finger flexion shows
    (`distance` scales how far back it stands)."""
    import mujoco

    palm = model.body("palm").id
    rotation = data.xmat[palm].reshape(3, 3)
    lookat = data.xpos[palm] + rotation @ np.array([0.0, -0.02, 0.085])
    eye = lookat + rotation @ np.array([0.2, -0.12, 0.05])
    forward = (lookat - eye) / np.linalg.norm(lookat - eye)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = lookat
    camera.distance = distance * float(np.linalg.norm(lookat - eye))
    camera.azimuth = float(np.degrees(np.arctan2(forward[1], forward[0])))
    camera.elevation = float(np.degrees(np.arcsin(forward[2])))
    return camera


def _draw_postures(postures: np.ndarray, size: int) -> np.ndarray:
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
    camera = _thumb_side_camera(model, data)
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


def _draw_scene(xml: str, states: np.ndarray, camera: str, width: int, height: int) -> np.ndarray:
    import mujoco

    model = mujoco.MjModel.from_xml_string(xml)
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, height, width)
    images = np.empty((len(states), height, width, 3), dtype=np.uint8)
    for i, state in enumerate(states):
        data.qpos[:] = state[: model.nq]
        data.mocap_pos[0], data.mocap_quat[0] = state[model.nq: model.nq + 3], state[model.nq + 3:]
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, _thumb_side_camera(model, data, 1.4) if camera == THUMB_SIDE else camera)
        image = renderer.render()
        if camera == THUMB_SIDE:
            image[image.max(axis=2) < 6] = 255  # white around the hand, as in the posture pictures
        images[i] = image
    renderer.close()
    return images


if __name__ == "__main__":
    with np.load(sys.argv[1]) as job:
        if str(job["kind"]) == "postures":
            pictures = _draw_postures(job["postures"], int(job["size"]))
        else:
            pictures = _draw_scene(str(job["xml"]), job["states"], str(job["camera"]), int(job["width"]),
                                   int(job["height"]))
    np.save(sys.argv[2], pictures)
