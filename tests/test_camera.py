"""Tests of pik_mj.robot.camera: intrinsics, projection, visibility, rendering, logging.

References: a hand computation of the pinhole model, MuJoCo's own
``camprojection`` sensor (MuJoCo projects a site into a camera), MuJoCo's
rendered image (the centroid of a small glowing sphere), and MuJoCo's
rendered colours for occlusion.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import rerun as rr

from pik_mj.exceptions import InvalidInput, RenderingUnavailable, UnknownName
from pik_mj.record import read_recording
from pik_mj.robot.camera import DEFAULT_SIZE, Camera, CameraRenderer, Intrinsics, log_camera
from pik_mj.robot.loading import load_model

# Camera "tilted" looks down at the table from the side; "sensor" has a physical
# sensor (focal, principal offset) instead of fovy; "plain" is MuJoCo's default
# orientation (looking along world -z, image x along world x).
MJCF = """
<mujoco>
  <visual><headlight ambient="0 0 0" diffuse="0 0 0" specular="0 0 0"/></visual>
  <asset>
    <material name="glow" rgba="1 0 0 1" emission="1"/>
    <material name="blue" rgba="0 0 1 1" emission="1"/>
  </asset>
  <worldbody>
    <camera name="plain" pos="0 0 2" fovy="60"/>
    <camera name="tilted" pos="0.1 -1.2 1.1" xyaxes="1 0.1 0 -0.05 0.6 0.8" fovy="50"
            resolution="400 300"/>
    <camera name="sensor" pos="0.05 0.02 1.5" focal="0.012 0.013" sensorsize="0.02 0.015"
            principal="0.001 -0.0015" resolution="200 150"/>
    <geom name="roof" type="box" pos="-0.09 -0.09 1.5" size="0.03 0.03 0.005" group="3"/>
    <body name="ball" mocap="true" pos="0 0 0.3">
      <geom name="ball" type="sphere" size="0.015" material="glow" contype="0" conaffinity="0"/>
      <site name="ball_centre"/>
    </body>
    <body name="shade" mocap="true" pos="3 0 1">
      <geom name="shade" type="box" size="0.1 0.1 0.01" material="blue"
            contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <sensor>
    <camprojection name="plain_px" site="ball_centre" camera="plain"/>
    <camprojection name="tilted_px" site="ball_centre" camera="tilted"/>
  </sensor>
</mujoco>
"""


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(MJCF)


def place(model: mujoco.MjModel, data: mujoco.MjData, ball=None, shade=None) -> None:
    if ball is not None:
        data.mocap_pos[model.body("ball").mocapid[0]] = ball
    if shade is not None:
        data.mocap_pos[model.body("shade").mocapid[0]] = shade
    mujoco.mj_forward(model, data)


def points_in_view(camera: Camera, data, n: int, margin_px: float, seed: int) -> np.ndarray:
    """``n`` random points of the box [-0.4, 0.4]² x [0, 0.8] that project at least
    ``margin_px`` inside the image."""
    rng = np.random.default_rng(seed)
    k = camera.intrinsics
    out = []
    while len(out) < n:
        p = rng.uniform([-0.4, -0.4, 0.0], [0.4, 0.4, 0.8])
        (u, v), depth = camera.project(data, p)
        if (
            depth > 0.2
            and margin_px < u < k.width - margin_px
            and margin_px < v < k.height - margin_px
        ):
            out.append(p)
    return np.array(out)


# --------------------------------------------------------------- intrinsics
def test_fovy_camera_intrinsics_by_hand(model):
    cam = Camera(model, "plain")
    assert (cam.intrinsics.width, cam.intrinsics.height) == DEFAULT_SIZE
    f = 0.5 * 240 / math.tan(math.radians(60) / 2)  # (h/2) / tan(fovy/2) = 207.846 px
    k = cam.intrinsics
    np.testing.assert_allclose([k.fx, k.fy, k.cx, k.cy], [f, f, 160, 120], rtol=1e-6)
    wide = Camera(model, "plain", width=640, height=200).intrinsics
    f = 100 / math.tan(math.radians(30))
    np.testing.assert_allclose([wide.fx, wide.fy, wide.cx, wide.cy], [f, f, 320, 100], rtol=1e-6)
    np.testing.assert_allclose(wide.K, [[f, 0, 320], [0, f, 100], [0, 0, 1]], rtol=1e-6)


def test_sensor_camera_intrinsics_by_hand(model):
    """focal (fx, fy) [m], principal offset (px, py) [m], sensor (sx, sy) [m] on
    W x H pixels: f_x = W fx/sx, c_x = W/2 − W px/sx, f_y = H fy/sy,
    c_y = H/2 − H py/sy (the frustum MuJoCo renders, see the rendering test)."""
    k = Camera(model, "sensor").intrinsics  # the MJCF's resolution 200 x 150
    assert (k.width, k.height) == (200, 150)
    expected = [
        200 * 0.012 / 0.02,
        150 * 0.013 / 0.015,
        100 - 200 * 0.001 / 0.02,
        75 + 150 * 0.0015 / 0.015,
    ]
    np.testing.assert_allclose([k.fx, k.fy, k.cx, k.cy], expected, rtol=1e-5)


# --------------------------------------------------------------- projection
def test_projection_by_hand(model):
    """The tilted camera's axes from its MJCF ``xyaxes`` (x, y orthonormalized,
    z = x × y), a point 0.3 m right, 0.1 m up and 1.2 m in front of it."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    x = np.array([1, 0.1, 0])
    x /= np.linalg.norm(x)
    y = np.array([-0.05, 0.6, 0.8])
    y -= (y @ x) * x
    y /= np.linalg.norm(y)
    z = np.cross(x, y)
    p = np.array([0.1, -1.2, 1.1]) + 0.3 * x + 0.1 * y - 1.2 * z
    f = 150 / math.tan(math.radians(25))  # the MJCF's resolution: 400 x 300
    cam = Camera(model, "tilted")
    uv, depth = cam.project(data, p)
    np.testing.assert_allclose(uv, [200 + f * 0.3 / 1.2, 150 - f * 0.1 / 1.2], atol=1e-9)
    assert depth == pytest.approx(1.2, abs=1e-12)
    # the same point behind the camera has a negative depth and is not in view
    behind = np.array([0.1, -1.2, 1.1]) + 1.2 * z
    assert cam.project(data, behind)[1] == pytest.approx(-1.2, abs=1e-12)
    assert not cam.in_view(data, behind)[0]
    assert cam.in_view(data, p)[0]


@pytest.mark.parametrize("name", ["plain", "tilted"])
def test_projection_equals_mujoco_camprojection_sensor(model, name):
    """MuJoCo's ``camprojection`` sensor projects the ball's site onto the
    camera's MJCF resolution (400 x 300 for "tilted"; "plain" sets none, for
    which MuJoCo's sensor uses 1 x 1, so the test compares at that size too)."""
    data = mujoco.MjData(model)
    res = tuple(int(r) for r in model.cam_resolution[model.camera(name).id])
    cam = Camera(model, name, width=res[0], height=res[1])
    place(model, data)
    for p in points_in_view(Camera(model, name), data, 20, 0.0, seed=1):
        place(model, data, ball=p)
        np.testing.assert_allclose(
            cam.project(data, p)[0], data.sensor(f"{name}_px").data, atol=1e-9
        )


# ----------------------------------------------------------------- rendering
@pytest.fixture(scope="module")
def renderers(model):
    """One renderer per image size; skipped only when no OpenGL backend works."""
    out = {}
    try:
        for size in ((320, 240), (400, 300), (200, 150), (240, 150)):
            out[size] = CameraRenderer(model, *size)
    except RenderingUnavailable as err:
        for r in out.values():
            r.close()
        pytest.skip(f"no MuJoCo offscreen rendering here: {err}")
    yield out
    for r in out.values():
        r.close()


def red_centroid(image: np.ndarray) -> np.ndarray | None:
    """Centroid (u, v) [px] of the glowing red pixels, pixel (i, j) centred at
    (i + 0.5, j + 0.5)."""
    mask = (image[..., 0] > 100) & (image[..., 1] < 60) & (image[..., 2] < 60)
    v, u = np.nonzero(mask)
    if len(u) < 3:
        return None
    return np.array([u.mean() + 0.5, v.mean() + 0.5])


@pytest.mark.parametrize(
    ("name", "size"),
    [("plain", (320, 240)), ("tilted", (400, 300)), ("sensor", (200, 150)), ("sensor", (240, 150))],
)
def test_projection_equals_rendered_position(model, renderers, name, size):
    """A 3 cm glowing sphere at random points in view: its centroid in MuJoCo's
    image is the projection of its centre within 2 px (measured: < 0.3 px).
    ("sensor" at 240 x 150 stretches the physical sensor onto another aspect
    ratio, as MuJoCo's renderer does.)"""
    data = mujoco.MjData(model)
    cam = Camera(model, name, width=size[0], height=size[1])
    place(model, data)
    errors = []
    for p in points_in_view(cam, data, 8, margin_px=12, seed=2):
        place(model, data, ball=p)
        seen = red_centroid(renderers[size].render(data, cam))
        assert seen is not None, f"sphere at {p} not rendered"
        errors.append(np.abs(seen - cam.project(data, p)[0]).max())
    assert max(errors) < 2.0, errors


# ------------------------------------------------------------------ occlusion
def test_occlusion_by_a_moving_box(model):
    """A box slides between the plain camera and the ball: visible -> occluded
    (by the box) -> visible, by MuJoCo's ray casting."""
    data = mujoco.MjData(model)
    ball = np.array([0.2, 0.1, 0.3])
    cam = Camera(model, "plain")
    states = []
    for x in (-1.0, 0.2, 1.4):  # the box at z = 1 passes over the ball at x = 0.2
        place(model, data, ball=ball, shade=[x, 0.1, 1.0])
        vis = cam.visibility(data, "ball")
        states.append((vis.in_view, vis.occluder))
        # the site on the ball is not occluded by the ball's own geom
        assert cam.visibility(data, "ball_centre").occluder == vis.occluder
        assert cam.visibility(data, ball).occluder in (vis.occluder, "ball")
    assert states == [(True, None), (True, "shade"), (True, None)]
    # a geom of the world body occludes the world camera too, when its group
    # (3, not rendered by default) is among the rays' groups
    assert cam.visibility(data, [-0.3, -0.3, 0.3]).visible
    all_groups = (1, 1, 1, 1, 0, 0)
    assert cam.visibility(data, [-0.3, -0.3, 0.3], geomgroup=all_groups).occluder == "roof"
    assert cam.visibility(data, [-0.3, -0.1, 0.3], geomgroup=all_groups).visible
    # a world point without a body: the ball's own geom hides its centre
    place(model, data, shade=[3, 0, 1])
    assert cam.visibility(data, ball).occluder == "ball"
    assert cam.visibility(data, ball + np.array([0, 0, 0.02])).visible


def test_occlusion_agrees_with_the_rendered_image(model, renderers):
    """Where ray casting says "occluded", the rendered pixel of the ball is the
    box's blue; where it says "visible", it is the ball's red."""
    data = mujoco.MjData(model)
    cam = Camera(model, "plain")
    for x, colour in ((-1.0, 0), (0.2, 2)):
        place(model, data, ball=[0.2, 0.1, 0.3], shade=[x, 0.1, 1.0])
        vis = cam.visibility(data, "ball")
        u, v = np.floor(vis.pixel).astype(int)
        pixel = renderers[(320, 240)].render(data, cam)[v, u]
        assert int(np.argmax(pixel)) == colour and pixel[colour] > 100
        assert vis.visible == (colour == 0)


def test_head_camera_of_the_sample_humanoid():
    """The head camera looks along head_end's gaze (x) with z up: a point 1.5 m
    ahead on that line is at the image centre; the robot's hands (below the
    60° field of view in the reset pose) are not in view; a body behind the
    robot is not either."""
    model = load_model("sample_humanoid")
    data = mujoco.MjData(model)
    data.qpos[:] = model.key_qpos[model.key("reset_pose").id]
    mujoco.mj_forward(model, data)
    cam = Camera(model, "head_camera")
    k = cam.intrinsics
    assert (k.width, k.height) == (320, 240)
    gaze = data.site("head_end").xmat.reshape(3, 3)[:, 0]
    ahead = data.site("head_end").xpos + 1.5 * gaze
    uv, depth = cam.project(data, ahead)
    np.testing.assert_allclose(uv, [160, 120], atol=1e-9)
    assert depth == pytest.approx(1.5 - 0.02, abs=1e-9)
    assert cam.visibility(data, ahead).visible
    assert not cam.visibility(data, "rarm_hand").in_view
    assert not cam.visibility(data, data.xpos[1] - [1.0, 0, 0]).in_view
    # the head itself is the camera's body: rays start inside it, it never occludes
    assert cam.visibility(data, ahead).occluder is None


# ------------------------------------------------------------------- logging
def test_log_camera_reads_back(model, tmp_path):
    data = mujoco.MjData(model)
    place(model, data)
    cam = Camera(model, "tilted", width=64, height=48)
    image = np.zeros((48, 64, 3), dtype=np.uint8)
    image[10:20, 30:40] = [255, 0, 0]
    path = tmp_path / "camera.rrd"
    stream = rr.RecordingStream("pik_mj_test", recording_id="camera")
    stream.save(path)
    stream.set_time("sim_time", duration=0.5)
    pinhole = log_camera(stream, cam, data, image=image)
    stream.flush()
    stream.disconnect()
    rec = read_recording(path)
    assert pinhole == "world/cameras/tilted/image"
    _, [mat] = rec["world/cameras/tilted/image"].series("Pinhole:image_from_camera", "sim_time")
    # rerun stores the 3x3 matrix column-major
    np.testing.assert_allclose(np.reshape(mat, (3, 3)).T, cam.intrinsics.K, rtol=1e-6)
    _, [res] = rec["world/cameras/tilted/image"].series("Pinhole:resolution", "sim_time")
    np.testing.assert_allclose(np.ravel(res), [64, 48])
    _, [t] = rec["world/cameras/tilted"].series("Transform3D:translation", "sim_time")
    np.testing.assert_allclose(np.ravel(t), data.cam_xpos[cam.id], rtol=1e-6)
    _, [m] = rec["world/cameras/tilted"].series("Transform3D:mat3x3", "sim_time")
    np.testing.assert_allclose(
        np.reshape(m, (3, 3)).T, data.cam_xmat[cam.id].reshape(3, 3), atol=1e-6
    )
    _, [buffer] = rec["world/cameras/tilted/image"].series("Image:buffer", "sim_time")
    np.testing.assert_array_equal(np.asarray(buffer, dtype=np.uint8).reshape(48, 64, 3), image)


# ----------------------------------------------------------------- bad input
def test_bad_input(model):
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with pytest.raises(UnknownName, match=r"camera 'nope'.*\['plain', 'sensor', 'tilted'\]"):
        Camera(model, "nope")
    with pytest.raises(InvalidInput, match="positive integers"):
        Camera(model, "plain", width=0)
    cam = Camera(model, "plain")
    with pytest.raises(InvalidInput, match=r"shape \(3,\) or \(n, 3\)"):
        cam.project(data, [1.0, 2.0])
    with pytest.raises(InvalidInput, match="finite"):
        cam.project(data, [1.0, np.nan, 0.0])
    with pytest.raises(UnknownName, match="frame 'nope'"):
        cam.visibility(data, "nope")
    with pytest.raises(InvalidInput, match="6 flags"):
        cam.visibility(data, "ball", geomgroup=(1, 1))
    with pytest.raises(InvalidInput, match=r"uint8 of shape \(240, 320, 3\)"):
        log_camera(rr.RecordingStream("x"), cam, data, image=np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(InvalidInput, match="offscreen buffer 640x480"):
        CameraRenderer(model, 1000, 100)
    ortho = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><camera name="o" projection="orthographic"/></worldbody></mujoco>'
    )
    with pytest.raises(InvalidInput, match="orthographic"):
        Camera(ortho, "o")
    assert isinstance(cam.intrinsics, Intrinsics)
