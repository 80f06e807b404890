"""Offscreen pictures of hand postures and of scenes with MuJoCo's renderer, on a headless machine,
and animations of them (GIF, through Pillow).

MuJoCo picks its OpenGL backend when it is first imported, from the MUJOCO_GL environment variable.
On a headless Linux machine where it is unset, `import graspmanifold` sets it, before MuJoCo's import,
to the offscreen backend whose library is installed (EGL, then OSMesa: `choose_offscreen_backend`), and
pictures are drawn in this process. Where that is not possible (MuJoCo was imported first, the variable
names another backend, or the in-process context fails) they are drawn by one child process started
with MUJOCO_GL set explicitly (EGL first, then OSMesa) and kept for the pictures that follow: the first
picture pays its start (about a second), later ones do not. Where no backend works,
`RenderingUnavailable` says what to install.
"""

from __future__ import annotations

import atexit
import ctypes.util
import io
import os
import platform
import subprocess
import sys
import threading
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..base.errors import InvalidInput, RenderingUnavailable
from ..base.validation import check_data, check_int

BACKENDS = ("egl", "osmesa")
#: a view for `render_states` besides a scene's named cameras: from the palm's thumb side, as the
#: hand pictures of the figures are drawn
THUMB_SIDE = "thumb_side"
HOW_TO_ENABLE = ("install an offscreen OpenGL driver (Debian/Ubuntu: apt-get install libegl1 libgl1 "
                 "libegl-mesa0 libosmesa6) so that MUJOCO_GL=egl or MUJOCO_GL=osmesa works")


#: the values of MUJOCO_GL that MuJoCo's import takes on this system
_MUJOCO_TAKES = ("disable", "disabled", "off", "false", "0", "enable", "enabled", "on", "true", "1", "glfw") + {
    "Linux": ("glx", "egl", "osmesa"), "Windows": ("wgl",), "Darwin": ("cgl",)}.get(platform.system(), ())


def choose_offscreen_backend() -> str | None:
    """On a headless Linux machine, before MuJoCo's first import and with MUJOCO_GL unset: set MUJOCO_GL
    (and PyOpenGL's platform) to the offscreen backend whose library is installed, EGL first, then OSMesa,
    so that pictures are drawn in this process. `import graspmanifold` calls it.

    A value of MUJOCO_GL that MuJoCo's import would refuse (it raises, and nothing of the library could run,
    not even what draws nothing) is dropped with a warning.

    Returns:
        The backend set, or None where nothing was changed (a display, MuJoCo already imported, the
        variable already set, no offscreen library, not Linux).
    """
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen and chosen not in _MUJOCO_TAKES and "mujoco" not in sys.modules:  # MuJoCo's import would fail
        warnings.warn(f"MUJOCO_GL={os.environ['MUJOCO_GL']!r} is not a value MuJoCo takes ({', '.join(_MUJOCO_TAKES)}):"
                      " ignored", stacklevel=2)
        del os.environ["MUJOCO_GL"]
    if (os.environ.get("MUJOCO_GL") or "mujoco" in sys.modules or not sys.platform.startswith("linux")
            or os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return None
    for backend, library, symbol in (("egl", "EGL", "eglQueryString"), ("osmesa", "OSMesa", "OSMesaCreateContextExt")):
        found = ctypes.util.find_library(library)
        if found and _loads(found, symbol, backend):
            os.environ["MUJOCO_GL"] = backend
            os.environ.setdefault("PYOPENGL_PLATFORM", backend)
            return backend
    return None


def _loads(library: str, symbol: str, backend: str) -> bool:
    """Whether the loader gives a working `library` (with `symbol`), as PyOpenGL will ask it inside MuJoCo's import;
    a broken one on the loader path (which killed `import graspmanifold` there) is passed over with one warning."""
    try:
        getattr(ctypes.CDLL(library), symbol)
    except (OSError, AttributeError) as error:
        warnings.warn(f"the offscreen OpenGL library {library} on the loader path cannot be used ({error}): not drawing "
                      f"with {backend} in this process; set MUJOCO_GL to choose another backend", stacklevel=3)
        return False
    return True


_in_process_failed = False  # this process's context failed once: the kept child draws from then on


class _DrawingProcess:
    """A child process that draws with one offscreen backend, kept alive for the pictures that follow.

    A job goes to its stdin and the images come back on its stdout, each as 8 bytes of length and an
    .npz / .npy payload (a status byte first on the way back). It ends with this process: when its
    stdin closes, and at exit."""

    def __init__(self, backend: str):
        env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
        self.backend = backend
        self.process = subprocess.Popen([sys.executable, "-m", "graspmanifold.sim.render", "--serve"], env=env,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)

    def draw(self, job: dict[str, np.ndarray]) -> np.ndarray:
        buffer = io.BytesIO()
        np.savez(buffer, **dict[str, Any](job))
        stdin, stdout, stderr = self.process.stdin, self.process.stdout, self.process.stderr
        assert stdin is not None and stdout is not None and stderr is not None  # opened as pipes
        try:
            stdin.write(len(buffer.getvalue()).to_bytes(8, "little") + buffer.getvalue())
            stdin.flush()
            header = stdout.read(9)
            payload = stdout.read(int.from_bytes(header[1:], "little")) if len(header) == 9 else b""
        except (BrokenPipeError, OSError):
            header, payload = b"", b""
        if len(header) == 9 and header[0] == 0:
            return np.load(io.BytesIO(payload))
        self.close()
        why = payload.decode(errors="replace") if header else stderr.read().decode(errors="replace")
        raise RenderingUnavailable(f"{self.backend}: {why.strip().splitlines()[-1:] or ['failed']}")

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()


_drawing: dict[str, _DrawingProcess] = {}  # the child kept for later pictures, by backend order
_drawing_lock = threading.Lock()


@atexit.register
def _close_drawing() -> None:
    for child in _drawing.values():
        child.close()
    _drawing.clear()


def _draw(job: dict[str, np.ndarray], backends: tuple[str, ...] | None) -> np.ndarray:
    """The images of a drawing job: in this process where MUJOCO_GL was set before MuJoCo's import,
    otherwise in the kept child process (started with each offscreen backend in turn until one works)."""
    global _in_process_failed
    in_process = ""
    if backends is None and os.environ.get("MUJOCO_GL") in BACKENDS and not _in_process_failed:
        try:
            return _draw_job(job)
        except Exception as error:  # noqa: BLE001 - no context in this process: the child may still draw
            _in_process_failed = True
            in_process = f"MUJOCO_GL={os.environ['MUJOCO_GL']} in this process: {error}"
    errors = [in_process] if in_process else []
    with _drawing_lock:
        for backend in backends or BACKENDS:
            kept = _drawing.pop(backend, None)
            for child in ([kept] if kept else []) + [None]:  # a kept child that died is started again once
                child = child or _DrawingProcess(backend)
                try:
                    images = child.draw(job)
                except RenderingUnavailable as error:
                    failure = str(error)
                    continue
                _drawing[backend] = child
                return images
            errors.append(failure)
    raise RenderingUnavailable(f"no offscreen OpenGL context ({'; '.join(errors)}); to enable, {HOW_TO_ENABLE}")


def render_postures(postures: np.ndarray, size: int = 160, backends: tuple[str, ...] | None = None,
                    hand: str | None = None) -> np.ndarray:
    """Images (n, size, size, 3) uint8 of the hand in each posture (n, 22), on a white background.

    Args:
        postures: (n, 22) finger joint angles in the paper's sense, rad.
        size: pixels, the side of each image.
        backends: OpenGL backends to try (default: MUJOCO_GL's, then each of `BACKENDS`).
        hand: the hand model drawn: a name or an MJCF path (`hand_models.hand_model`); None: ours (`hand.SHADOW_HAND`).

    Returns:
        The images.

    Raises:
        InvalidInput: postures not finite (n, 22), a size outside 16-4096 pixels.
    """
    from .hand import SHADOW_HAND  # MuJoCo is imported after MUJOCO_GL is chosen
    from .hand_models import hand_name

    postures = check_data(np.asarray(postures, dtype=float).reshape(-1, 22), 22, "postures")
    size = check_int(size, "size (pixels)", low=16, high=4096)
    return _draw({"kind": np.array("postures"), "postures": postures, "size": np.array(size),
                  "hand": np.array(hand_name(hand or SHADOW_HAND.name))}, backends)


class SceneToDraw(Protocol):
    """What `render_states` draws: a `scene.Scene` (the model and its spec, the hand, its state's layout); pictures
    sit below the scene, which draws itself with them."""

    model: Any  # mujoco.MjModel
    spec: Any  # mujoco.MjSpec
    hand: Any  # hand.HandModel (its `palm` body's name)

    def state(self) -> np.ndarray: ...


def render_states(scene: SceneToDraw, states: np.ndarray, camera: str = "hand", width: int = 320, height: int = 240,
                  backends: tuple[str, ...] | None = None) -> np.ndarray:
    """Images (k, height, width, 3) uint8 of a scene in each of k states (`Scene.state()`), from
    one of its named cameras (`scene.CAMERAS`) or from the palm's thumb side (`THUMB_SIDE`)."""
    cameras = tuple(scene.model.camera(i).name for i in range(scene.model.ncam)) + (THUMB_SIDE,)
    if camera not in cameras:
        raise InvalidInput(f"unknown camera {camera!r}; expected one of {cameras}")
    for name, value in (("width", width), ("height", height)):
        check_int(value, f"{name} (pixels)", low=16, high=4096)
    states = np.asarray(states, dtype=float)
    if states.ndim != 2 or states.shape[1] != len(scene.state()) or not np.all(np.isfinite(states)):
        raise InvalidInput(f"states must be finite with shape (k, {len(scene.state())}) (Scene.state()), "
                         f"got {states.shape}")
    return _draw({"kind": np.array("scene"), "xml": np.array(scene.spec.to_xml()), "states": states,
                  "camera": np.array(camera), "width": np.array(int(width)), "height": np.array(int(height)),
                  "palm": np.array(scene.hand.palm)}, backends)


def png_bytes(image: np.ndarray) -> bytes:
    """An RGB image (h, w, 3) uint8 as PNG bytes."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def save_animation(frames: np.ndarray, path: str | os.PathLike, fps: float = 25.0) -> Path:
    """Write frames (k, h, w, 3) uint8 as an animated GIF that loops (Pillow), atomically."""
    from PIL import Image

    from ..base.io import atomic_write

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or not len(frames):
        raise InvalidInput(f"frames must have shape (k, height, width, 3) with k >= 1, got {frames.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidInput(f"fps must be positive, got {fps!r}")
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise InvalidInput(f"path must end in .gif, got {str(path)!r}")
    images = [Image.fromarray(frame.astype(np.uint8)) for frame in frames]
    with atomic_write(path) as handle:
        images[0].save(handle, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    return path


def _thumb_side_camera(model, data, distance: float = 1.0, palm: str = "palm"):
    """A free camera on the palm's thumb side, level with the fingers: finger flexion shows
    (`distance` scales how far back it stands; `palm` is the hand's palm body)."""
    import mujoco

    palm = model.body(palm).id
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


def _draw_postures(postures: np.ndarray, size: int, hand: str) -> np.ndarray:
    import mujoco

    from .hand_models import hand_model
    from .posture import posture_to_ctrl

    model_hand = hand_model(hand)
    model = model_hand.spec().compile()
    hidden = [model.body(name).id for name in model_hand.base_segments[:2]]  # forearm and wrist: the palm and fingers
    model.geom_rgba[np.isin(model.geom_bodyid, hidden), 3] = 0.0  # are the subject
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, size)
    model.vis.global_.offheight = max(model.vis.global_.offheight, size)
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, size, size)
    finger_qpos = np.array([model.joint(name).qposadr[0] for name in model_hand.finger_joints])
    actuators = np.array([model.actuator(name).id for name in model_hand.actuators])
    _turn_palm_as_ours(model, data, model_hand)
    camera = _thumb_side_camera(model, data, palm=model_hand.palm)
    images = np.empty((len(postures), size, size, 3), dtype=np.uint8)
    for i, posture in enumerate(postures):
        data.qpos[finger_qpos] = model_hand.to_model(posture)
        data.ctrl[actuators] = posture_to_ctrl(posture, hand=model_hand)
        mujoco.mj_kinematics(model, data)
        renderer.update_scene(data, camera)
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False  # a model's own sky (Gymnasium-Robotics')
        image = renderer.render()
        image[image.max(axis=2) < 6] = 255  # a white background instead of the empty black scene
        images[i] = image
    renderer.close()
    return images


def _turn_palm_as_ours(model, data, hand) -> None:
    """Turn the hand's mount so that its palm faces the world as ours does on an unturned mount (a free camera
    keeps the world's z up: every hand is then seen alike)."""
    import mujoco

    from .hand import SHADOW_HAND

    ours = mujoco.MjData(SHADOW_HAND.model)
    mujoco.mj_kinematics(SHADOW_HAND.model, ours)
    mujoco.mj_kinematics(model, data)
    mount, palm = model.body(hand.mount), model.body(hand.palm).id
    turn = ours.xmat[SHADOW_HAND.model.body(SHADOW_HAND.palm).id].reshape(3, 3) @ data.xmat[palm].reshape(3, 3).T
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (turn @ data.xmat[mount.id].reshape(3, 3)).ravel())
    data.mocap_quat[mount.mocapid[0]] = quat
    mujoco.mj_forward(model, data)


def _draw_scene(xml: str, states: np.ndarray, camera: str, width: int, height: int, palm: str) -> np.ndarray:
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
        renderer.update_scene(data, _thumb_side_camera(model, data, 1.4, palm) if camera == THUMB_SIDE else camera)
        if camera == THUMB_SIDE:
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        image = renderer.render()
        if camera == THUMB_SIDE:
            image[image.max(axis=2) < 6] = 255  # white around the hand, as in the posture pictures
        images[i] = image
    renderer.close()
    return images


def _draw_job(job: Mapping[str, np.ndarray]) -> np.ndarray:
    """The images of one drawing job (`render_postures` / `render_states` make them)."""
    if str(job["kind"]) == "postures":
        return _draw_postures(job["postures"], int(job["size"]), str(job["hand"]))
    return _draw_scene(str(job["xml"]), job["states"], str(job["camera"]), int(job["width"]), int(job["height"]),
                       str(job["palm"]))


def _serve() -> None:
    """The drawing child's loop (`_DrawingProcess`): jobs from stdin, images (or why not) to stdout."""
    replies = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # whatever MuJoCo or OpenGL print goes to stderr, not into the replies
    requests = sys.stdin.buffer
    while len(size := requests.read(8)) == 8:
        with np.load(io.BytesIO(requests.read(int.from_bytes(size, "little")))) as job:
            try:
                buffer = io.BytesIO()
                np.save(buffer, _draw_job(job))
                status, payload = 0, buffer.getvalue()
            except Exception as error:  # noqa: BLE001 - told to the parent, which decides
                status, payload = 1, f"{type(error).__name__}: {error}".encode()
        replies.write(bytes([status]) + len(payload).to_bytes(8, "little") + payload)
        replies.flush()


if __name__ == "__main__" and sys.argv[1:] == ["--serve"]:
    _serve()
