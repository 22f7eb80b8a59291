"""Frame matching (prioritized-IK manual: ``move-target-task``; irteus manual:
``:move-target``, ``:target-coords``).

A frame ``M`` (the move target, on the robot) is brought onto a frame ``T`` (the
target: a fixed pose, a callable evaluated every iteration, or another frame of
the robot, in which case both move and the Jacobian is relative). Errors, in a
frame ``F`` (``"local"`` = ``M``, ``"world"``, or a given rotation ``R_WF``):

.. math::

    e_t = R_{WF}^T (p_{WM} - p_{WT}), \\qquad
    e_r = R_{WF}^T \\log(R_{WM} R_{WT}^T)

with Jacobians (``J_p``, ``J_ω`` world-frame, from MuJoCo, ``J_l^{-1}`` the
inverse left Jacobian of SO(3), ``R_e = R_{WM} R_{WT}^T``):

.. math::

    J_t = R_{WF}^T \\big(J_{p,M} - J_{p,T} + [e_{t,W}]_\\times J_{\\omega,F}\\big), \\qquad
    J_r = R_{WF}^T \\big(J_l^{-1}(e_{r,W}) (J_{\\omega,M} - R_e J_{\\omega,T})
          + [e_{r,W}]_\\times J_{\\omega,F}\\big)

(the last terms appear only when ``F`` turns with the robot). Rows are the
components *not* freed by the axis selection, following irteus: naming an axis
frees it — ``translation_axis="z"`` leaves motion along z free (x, y matched),
``"xy"`` matches z only, ``rotation_axis="z"`` leaves rotation about z free.
The whole pose in the move target's frame (all six rows, both frames
``"local"``, the default) is matched by default through its **twist** error
(``error_type="twist"``), mink's body twist from the target to the move target:

.. math::

    e = \\log(T_{WT}^{-1} T_{WM})
      = \\big(J_l^{-1}(\\phi)\\, R_{WT}^T (p_{WM} - p_{WT}),\\ \\phi\\big),
    \\qquad \\phi = \\log(R_{WT}^T R_{WM}),

with ``J = J_r^{-1}(e) V`` where ``V`` is the body twist Jacobian (mink's
``FrameTask``, or ``RelativeFrameTask`` for a robot-frame target, compute both:
:mod:`pik_mj.tasks.twist`). The motion of one revolute joint is a straight
line in these coordinates, so Newton steps on them follow the arcs a limb
makes, where the prioritized-IK manual's ``(e_t, e_r)`` above
(``error_type="split"``, always used with axis selection or other frames)
cuts across them. ``φ`` is ``e_r``; the twist's translation part differs from
``e_t`` by ``O(θ ‖e_t‖)``. The stop test, the reported error and
:meth:`FrameTask.pose_error` are the split error either way: ``thre`` bounds
the distance between the two origins.

Each iteration asks ``J x = -clamp(e)``, the translation clamped to norm
``p_limit`` [m] and the rotation to ``r_limit`` [rad] (prioritized-IK manual:
``p-limit``, ``r-limit``) when given. By default nothing is clamped:
:func:`pik_mj.solve`'s trust region bounds every step instead (docs/priority.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.inputs import as_pose, rotation_matrix
from pik_mj.spatial import (
    ljacinv,
    ljacinv_rows,
    matrix_to_quat,
    quat_log,
    rotation_vector,
    skew,
)
from pik_mj.tasks.task import (
    EqualityTask,
    TaskRows,
    TaskState,
    clamp_norm,
    diagonal_weights,
    no_inequality,
    tolerance,
    within,
)
from pik_mj.tasks.twist import Twist, twist_distances

AxisSpec = bool | str | None

ONE_DEGREE = float(np.deg2rad(1.0))
"""Default rotation tolerance [rad] (prioritized-IK manual: ``rthre``, 1 degree)."""

ERROR_TYPES = ("twist", "split")
"""The errors a :class:`FrameTask` can ask of its rows (module docstring)."""

_AXES = {"x": 0, "y": 1, "z": 2}

_POSE = {
    "body": ("xpos", "xmat"),
    "site": ("site_xpos", "site_xmat"),
    "geom": ("geom_xpos", "geom_xmat"),
}
"""Where MuJoCo keeps each frame type's world position and rotation (read in place)."""


def constrained_axes(spec: AxisSpec, what: str) -> np.ndarray:
    """Indices of the matched components for an irteus axis specification.

    ``True``/``"t"``: all three; ``None``/``False``: none; ``"x"``: x free (y, z
    matched); ``"xy"``: x and y free (z matched); and so on.
    """
    if spec is True or spec == "t":
        return np.arange(3)
    if spec is None or spec is False:
        return np.arange(0)
    if isinstance(spec, str) and 1 <= len(spec) <= 2 and set(spec) <= set(_AXES):
        free = {_AXES[c] for c in spec}
        return np.array([i for i in range(3) if i not in free], dtype=int)
    raise InvalidInput(
        f"{what} {spec!r} is not valid; use True/'t', None, 'x', 'y', 'z', 'xy', 'yz', 'zx'"
    )


class FrameTask(EqualityTask):
    """Bring a robot frame onto a target frame (prioritized-IK manual: ``move-target-task``).

    Args:
        configuration: Robot configuration (for name lookup).
        move_target: Name of the robot frame to move (site, body or geom).
        target: A fixed pose (``mink.SE3``, 4x4, or ``(p, quat_wxyz)``), the name
            of another robot frame (both move), or a callable
            ``f(configuration) -> pose`` evaluated every iteration.
        move_target_type: ``"site"``, ``"body"``, ``"geom"`` or None (search).
        target_type: Same for a named target frame.
        translation_axis: Axis selection, see :func:`constrained_axes`.
        rotation_axis: Axis selection, see :func:`constrained_axes`.
        translation_frame: ``"local"`` (the move target), ``"world"``, or a fixed
            rotation (3x3, quaternion wxyz or ``mink.SO3``) in which the
            translation error, its axes and weights are expressed.
        rotation_frame: Same for the rotation error.
        w_trans: Translation weight(s), float or 3-vector in ``translation_frame``
            [cost/m²].
        w_rot: Rotation weight(s) [cost/rad²].
        thre: Stop-test translation tolerance [m] (float on the norm, or
            per-axis vector).
        rthre: Stop-test rotation tolerance [rad].
        p_limit: Largest translation asked of one iteration [m] (the
            prioritized-IK manual's default: 0.1); None: no clamp.
        r_limit: Largest rotation asked of one iteration [rad] (the
            prioritized-IK manual's default: 0.5); None: no clamp.
        check: Whether the solve loop's stop test looks at this task.
        name: Display name.
        error_type: The rows' error (module docstring): ``"twist"`` (the pose's
            body twist ``log(T_WT⁻¹ T_WM)``; all six rows in the ``"local"``
            frames only) or ``"split"`` (the prioritized-IK manual's ``(e_t, e_r)``). None: the
            twist where it applies, else the split.
    """

    # MuJoCo's Jacobians and poses at a finite configuration, targets and
    # weights checked finite where they are set
    finite_rows = True

    def __init__(
        self,
        configuration: mink.Configuration,
        move_target: str,
        target: Any,
        *,
        move_target_type: str | None = None,
        target_type: str | None = None,
        translation_axis: AxisSpec = True,
        rotation_axis: AxisSpec = True,
        translation_frame: Any = "local",
        rotation_frame: Any = "local",
        w_trans: float | np.ndarray = 1.0,
        w_rot: float | np.ndarray = 1.0,
        thre: float | np.ndarray = 1e-3,
        rthre: float | np.ndarray = ONE_DEGREE,
        p_limit: float | None = None,
        r_limit: float | None = None,
        check: bool = True,
        name: str | None = None,
        error_type: str | None = None,
    ):
        model = self.model = configuration.model
        self.move_target = Frame.find(model, move_target, move_target_type)
        self.target_frame: Frame | None = None
        self.target_fn: Callable[[mink.Configuration], Any] | None = None
        self.target_pose: tuple[np.ndarray, np.ndarray] | None = None
        self._conjugate_of: tuple[np.ndarray, np.ndarray] | None = None
        self._conjugate: _TargetTerms
        self.set_target(target, target_type, model)
        self.trans_rows = constrained_axes(translation_axis, "translation_axis")
        self.rot_rows = constrained_axes(rotation_axis, "rotation_axis")
        self.translation_frame = self._frame_option(translation_frame, "translation_frame")
        self.rotation_frame = self._frame_option(rotation_frame, "rotation_frame")
        self.w_trans = diagonal_weights(w_trans, 3, "w_trans")
        self.w_rot = diagonal_weights(w_rot, 3, "w_rot")
        self.p_limit = _limit("p_limit", p_limit)
        self.r_limit = _limit("r_limit", r_limit)
        self.thre = tolerance(thre, "thre", "m")
        self.rthre = tolerance(rthre, "rthre", "rad")
        self.check = check
        self.name = name or f"frame:{move_target}"
        self.weights = np.concatenate([self.w_trans[self.trans_rows], self.w_rot[self.rot_rows]])
        self._rows = np.concatenate([self.trans_rows, 3 + self.rot_rows])
        self.k = self._rows.size
        self._both_local = all(
            isinstance(f, str) and f == "local"
            for f in (self.translation_frame, self.rotation_frame)
        )
        self._body = self.move_target.body_id  # the body carrying the move target
        self.error_type = self._error_type(error_type)
        # mink's twist task, made here and whenever the target changes (a
        # callable's pose is set on it at each evaluation)
        self._twist = Twist(self.move_target)
        if self.error_type == "twist":
            self._twist_toward(None)

    def _error_type(self, requested: str | None) -> str:
        """``"twist"`` or ``"split"``: the requested one, checked, or the default."""
        whole_local_pose = self._both_local and self._rows.size == 6
        if requested is None:
            return "twist" if whole_local_pose else "split"
        if requested not in ERROR_TYPES:
            raise InvalidInput(f"error_type {requested!r} is not one of {ERROR_TYPES} or None")
        if requested == "twist" and not whole_local_pose:
            raise InvalidInput(
                "error_type='twist' matches the whole pose in the move target's frame: it "
                "needs translation_axis=True, rotation_axis=True and both frames 'local' "
                "(use error_type='split' with axis selection or other frames)"
            )
        return requested

    # -- configuration ------------------------------------------------------
    def set_target(
        self, target: Any, target_type: str | None = None, model: mujoco.MjModel | None = None
    ) -> None:
        """Change the target: a pose, a robot frame name, or a callable."""
        self.target_frame, self.target_fn, self.target_pose = None, None, None
        if isinstance(target, str):
            self.target_frame = Frame.find(model or self.move_target.model, target, target_type)
        elif callable(target) and not isinstance(target, (mink.SE3, np.ndarray)):
            self.target_fn = target
        else:
            # the task's own read-only copy: what the target's quaternion is
            # derived from (once, see _target_point_and_conjugate) cannot change
            p, R = (a.copy() for a in as_pose(target, "target"))
            p.flags.writeable = R.flags.writeable = False
            self.target_pose = (p, R)
        if getattr(self, "error_type", None) == "twist":  # (__init__ makes it itself)
            self._twist_toward(None)

    @staticmethod
    def _frame_option(value: Any, what: str) -> str | np.ndarray:
        if isinstance(value, str):
            if value not in ("local", "world"):
                raise InvalidInput(f"{what} {value!r}: use 'local', 'world' or a rotation")
            return value
        return rotation_matrix(value, what, "'local', 'world'")

    # -- geometry -----------------------------------------------------------
    def target_pose_now(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray]:
        """``(p_WT, R_WT)`` at the current configuration."""
        if self.target_frame is not None:
            data = configuration.data
            return self.target_frame.position(data), self.target_frame.rotation(data)
        if self.target_fn is not None:
            return as_pose(self.target_fn(configuration), f"{self.name} target callable")
        assert self.target_pose is not None
        return self.target_pose

    def _target_point_and_conjugate(self, configuration: mink.Configuration) -> _TargetTerms:
        """``p_WT`` (array and floats) and the conjugate of ``R_WT``'s wxyz
        quaternion, for a fixed (derived once per pose) or callable target."""
        pose = self.target_pose
        if self.target_fn is None and pose is not None:
            if self._conjugate_of is not pose:
                self._conjugate = _point_and_conjugate(*pose)
                self._conjugate_of = pose
            return self._conjugate
        return _point_and_conjugate(*self.target_pose_now(configuration))

    def _R_WF(self, option: str | np.ndarray, R_WM: np.ndarray) -> np.ndarray:
        if isinstance(option, str):
            return R_WM if option == "local" else np.eye(3)
        return option

    def _errors_world(
        self, configuration: mink.Configuration
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(e_tW, e_rW, R_WM, R_e)``: world-frame errors [m, rad] and rotations."""
        data = configuration.data
        p_WM, R_WM = self.move_target.position(data), self.move_target.rotation(data)
        p_WT, R_WT = self.target_pose_now(configuration)
        R_e = R_WM @ R_WT.T
        return p_WM - p_WT, rotation_vector(R_e), R_WM, R_e

    def _in_frames(self, e_tW: np.ndarray, e_rW: np.ndarray, R_WM: np.ndarray) -> np.ndarray:
        """``[e_t; e_r]`` (6,) in the translation and rotation frames, all axes."""
        e = np.empty(6)
        e[:3] = self._R_WF(self.translation_frame, R_WM).T @ e_tW
        e[3:] = self._R_WF(self.rotation_frame, R_WM).T @ e_rW
        return e

    def pose_error(self, configuration: mink.Configuration) -> np.ndarray:
        """The split error, selected ``[e_t; e_r]`` in their frames [m, rad],
        whatever :attr:`error_type`: what ``thre``/``rthre`` and the reported
        error measure (``‖e_t‖`` is the distance between the two origins)."""
        if self._both_local and self.target_frame is None:
            e = np.array(self._local_error(configuration)[0])
            return e if self._rows.size == 6 else e[self._rows]
        e_tW, e_rW, R_WM, _ = self._errors_world(configuration)
        return self._in_frames(e_tW, e_rW, R_WM)[self._rows]

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """The rows' error, unclamped: the twist ``log(T_WT⁻¹ T_WM)`` or the
        split ``[e_t; e_r]`` (:attr:`error_type`) [m, rad]."""
        if self.error_type == "twist":
            return self._twist_error(configuration, jacobian=False)[0]
        return self.pose_error(configuration)

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """``d e / d q`` in the tangent space, shape (rows, nv)."""
        return self.error_and_jacobian(configuration)[1]

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        """Stop test on :meth:`pose_error`."""
        return self.satisfied_by(self.pose_error(configuration))

    def _twist_toward(self, configuration: mink.Configuration | None) -> None:
        """Point :attr:`_twist` at this task's target: the target frame, the
        fixed pose, or the callable's pose at ``configuration`` (None: not
        evaluated yet)."""
        if self.target_frame is not None:
            self._twist.toward_frame(self.target_frame)
        elif self.target_fn is None:
            self._twist.toward_pose(self.target_pose)
        elif configuration is not None:
            self._twist.toward_pose(self.target_pose_now(configuration))
        else:
            self._twist.toward_pose(None)

    def _twist_error(
        self, configuration: mink.Configuration, jacobian: bool = True, negated: bool = False
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The twist error (6,), or with ``negated`` its negative, and, if
        asked, its Jacobian (6, nv), from mink (:class:`~pik_mj.tasks.twist.Twist`)."""
        self._twist_toward(configuration)
        return self._twist.error(configuration, jacobian, negated)

    def error_and_jacobian(
        self, configuration: mink.Configuration
    ) -> tuple[np.ndarray, np.ndarray]:
        """Selected error (rows,) and its Jacobian (rows, nv), see the module formulas."""
        if self.error_type == "twist":
            return self._twist_error(configuration)
        if self._both_local and self.target_frame is None:
            e6, J = self._local(configuration)
            e = np.array(e6)
            if self._rows.size < 6:
                e, J = e[self._rows], J[self._rows]
            return e, J
        data = configuration.data
        e_tW, e_rW, R_WM, R_e = self._errors_world(configuration)
        Jp_M, Jr_M = self.move_target.jacobians(data)
        nv = Jp_M.shape[1]
        J = np.empty((2, 3, nv))  # [translation; rotation] blocks
        if self.target_frame is not None:
            Jp_T, Jr_T = self.target_frame.jacobians(data)
            np.subtract(Jp_M, Jp_T, out=J[0])
            J[1] = ljacinv(e_rW) @ (Jr_M - R_e @ Jr_T)
        else:
            J[0] = Jp_M
            J[1] = ljacinv(e_rW) @ Jr_M
        if self._both_local:  # the default: one batched product for both blocks
            tx, ty, tz = e_tW.tolist()
            rx, ry, rz = e_rW.tolist()
            S = np.array(  # [[e_t]×; [e_r]×]
                [
                    [[0.0, -tz, ty], [tz, 0.0, -tx], [-ty, tx, 0.0]],
                    [[0.0, -rz, ry], [rz, 0.0, -rx], [-ry, rx, 0.0]],
                ]
            )
            J += S @ Jr_M
            J = R_WM.T @ J
            e = (np.array([[tx, ty, tz], [rx, ry, rz]]) @ R_WM).reshape(6)
        else:
            for block, e_W, option in (
                (J[0], e_tW, self.translation_frame),
                (J[1], e_rW, self.rotation_frame),
            ):
                if isinstance(option, str):
                    if option == "local":
                        block += skew(e_W) @ Jr_M
                        block[:] = R_WM.T @ block
                else:
                    block[:] = option.T @ block
            e = self._in_frames(e_tW, e_rW, R_WM)
        J = J.reshape(6, nv)
        if self._rows.size < 6:
            e, J = e[self._rows], J[self._rows]
        return e, J

    def _local_error(
        self, configuration: mink.Configuration
    ) -> tuple[tuple[float, float, float, float, float, float], np.ndarray, list[float]]:
        """The default case's split error as six Python floats, with ``p_WT``
        and ``R_WM`` (row-major floats), see :meth:`_local`."""
        frame = self.move_target
        data = configuration.data
        i = frame.id
        if frame.frame_type == "body":
            w, x, y, z = data.xquat[i].tolist()  # MuJoCo's, R_WM = quat2Mat(xquat)
            p_WM, R_WM = data.xpos[i], data.xmat[i]
        else:
            xpos, xmat = _POSE[frame.frame_type]
            p_WM, R_WM = getattr(data, xpos)[i], getattr(data, xmat)[i]
            w, x, y, z = matrix_to_quat(R_WM).tolist()
        p_WT, (px, py, pz), (cw, cx, cy, cz) = self._target_point_and_conjugate(configuration)
        # q = q_WT^* q_WM, the rotation R_WT^T R_WM
        qw = cw * w - cx * x - cy * y - cz * z
        qx = cw * x + cx * w + cy * z - cz * y
        qy = cw * y - cx * z + cy * w + cz * x
        qz = cw * z + cx * y - cy * x + cz * w
        rx, ry, rz = quat_log(qw, qx, qy, qz)
        R = R_WM.tolist()
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = R
        mx, my, mz = p_WM.tolist()
        dx, dy, dz = mx - px, my - py, mz - pz
        tx = r0 * dx + r3 * dy + r6 * dz
        ty = r1 * dx + r4 * dy + r7 * dz
        tz = r2 * dx + r5 * dy + r8 * dz
        return (tx, ty, tz, rx, ry, rz), p_WT, R

    def _local(self, configuration: mink.Configuration) -> tuple[tuple[float, ...], np.ndarray]:
        """The default case (errors in the move target's frame, fixed or callable
        target): ``(e, J)`` with the error's six components as Python floats
        and the full Jacobian (6, nv). With ``R = R_WM``, ``e_t = R^T (p_WM - p_WT)``,
        ``e_r = R^T log(R_WM R_WT^T) = log(R_WT^T R_WM)`` (``R^T log(X) R = log(R^T X R)``),
        and

        .. math::

            J = \\begin{bmatrix} R^T & 0 \\\\ 0 & J_l^{-1}(-e_r) R^T \\end{bmatrix}
                \\begin{bmatrix} J_{p}(p_{WT}) \\\\ J_\\omega \\end{bmatrix}

        where ``J_p(p_WT) = J_{p,M} + [e_{t,W}]_\\times J_\\omega`` is MuJoCo's
        ``mj_jac`` of the point ``p_WT`` carried by the move target's body, and
        ``R^T J_l^{-1}(-e_{r,W}) = J_l^{-1}(-e_r) R^T`` (``J_l^{-1}(-e)`` is the
        inverse right Jacobian). The same rows as the module formulas, made from
        Python floats and one 6x6 product: the solve evaluates this several
        times per iteration (trial step and corrections), and numpy's per-call
        cost on 3x3 arrays is most of the work otherwise.
        """
        model, data = configuration.model, configuration.data
        (tx, ty, tz, rx, ry, rz), p_WT, R = self._local_error(configuration)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = R
        # L = J_l^{-1}(-e_r), written out as in ljacinv_rows; then L R^T
        (l00, l01, l02), (l10, l11, l12), (l20, l21, l22) = ljacinv_rows(-rx, -ry, -rz)
        # fmt: off
        M = np.array([
            r0, r3, r6, 0.0, 0.0, 0.0,
            r1, r4, r7, 0.0, 0.0, 0.0,
            r2, r5, r8, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0,
            l00 * r0 + l01 * r1 + l02 * r2, l00 * r3 + l01 * r4 + l02 * r5,
            l00 * r6 + l01 * r7 + l02 * r8,
            0.0, 0.0, 0.0,
            l10 * r0 + l11 * r1 + l12 * r2, l10 * r3 + l11 * r4 + l12 * r5,
            l10 * r6 + l11 * r7 + l12 * r8,
            0.0, 0.0, 0.0,
            l20 * r0 + l21 * r1 + l22 * r2, l20 * r3 + l21 * r4 + l22 * r5,
            l20 * r6 + l21 * r7 + l22 * r8,
        ])  # [[R^T, 0], [0, L R^T]], row by row
        # fmt: on
        jac = np.empty((6, model.nv))
        mujoco.mj_jac(model, data, jac[:3], jac[3:], p_WT, self._body)
        return (tx, ty, tz, rx, ry, rz), M.reshape(6, 6) @ jac

    # -- cascade contract -------------------------------------------------------
    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, ``‖e‖`` and stop test from one evaluation; the default case
        (all six rows in the move target's frame, fixed or callable target,
        tolerances on the norms) clamps and tests the error as Python floats,
        as :meth:`clamp` and :meth:`satisfied_by` do on arrays. With the twist
        error the rows come from it and the error and stop test from
        :meth:`pose_error`."""
        if self.error_type == "twist":
            # b = -clamp(e) = clamp(-e) (a clamp scales norms), copied only to clamp
            b, J = self._twist_error(configuration, negated=True)
            ux, uy, uz, rx, ry, rz = b.tolist()
            e6 = (-ux, -uy, -uz, -rx, -ry, -rz)
            if self.p_limit < math.inf or self.r_limit < math.inf:
                b = self.clamp(b)
            rows = TaskRows(J, b, self.weights, *no_inequality(J.shape[1]))
            if self.thre.ndim or self.rthre.ndim:  # per-axis tolerances
                split = self.pose_error(configuration)
                return TaskState(rows, math.sqrt(float(split @ split)), self.satisfied_by(split))
            n_t, n_r = twist_distances(*e6)
            return TaskState(
                rows,
                math.sqrt(n_t * n_t + n_r * n_r),
                n_t <= float(self.thre) and n_r <= float(self.rthre),
            )
        if not (
            self._both_local
            and self.target_frame is None
            and self._rows.size == 6
            and self.thre.ndim == 0
            and self.rthre.ndim == 0
        ):
            return super().evaluate(configuration)
        (tx, ty, tz, rx, ry, rz), J = self._local(configuration)
        t2 = tx * tx + ty * ty + tz * tz
        r2 = rx * rx + ry * ry + rz * rz
        n_t, n_r = math.sqrt(t2), math.sqrt(r2)
        s_t = -self.p_limit / n_t if n_t > self.p_limit else -1.0
        s_r = -self.r_limit / n_r if n_r > self.r_limit else -1.0
        b = np.array([s_t * tx, s_t * ty, s_t * tz, s_r * rx, s_r * ry, s_r * rz])
        return TaskState(
            TaskRows(J, b, self.weights, *no_inequality(J.shape[1])),
            math.sqrt(t2 + r2),
            n_t <= float(self.thre) and n_r <= float(self.rthre),
        )

    def clamp(self, e: np.ndarray) -> np.ndarray:
        """``[clamp(e_t, p_limit); clamp(e_r, r_limit)]`` (a copy)."""
        b = e.copy()
        n_t = self.trans_rows.size
        if self.p_limit < math.inf:
            clamp_norm(b[:n_t], self.p_limit)
        if self.r_limit < math.inf:
            clamp_norm(b[n_t:], self.r_limit)
        return b

    def satisfied_by(self, e: np.ndarray) -> bool:
        """Stop test on the split error ``e`` (:meth:`pose_error`): ``thre`` on
        the translation, ``rthre`` on the rotation (norms, or per axis)."""
        n_t = self.trans_rows.size
        return within(e[:n_t], self.thre, self.trans_rows) and within(
            e[n_t:], self.rthre, self.rot_rows
        )

    def __repr__(self) -> str:
        target = (
            self.target_frame
            if self.target_frame is not None
            else ("callable" if self.target_fn is not None else "fixed pose")
        )
        return (
            f"FrameTask(name={self.name!r}, move_target={self.move_target}, target={target}, "
            f"rows={self.trans_rows.size}+{self.rot_rows.size}, p_limit={self.p_limit}, "
            f"r_limit={self.r_limit})"
        )


_TargetTerms = tuple[np.ndarray, tuple[float, float, float], tuple[float, float, float, float]]


def _point_and_conjugate(p: np.ndarray, R: np.ndarray) -> _TargetTerms:
    """``(p, p as floats, q^*)``: ``p`` as a contiguous float array (MuJoCo's
    point argument) and the conjugate of ``R``'s wxyz quaternion, as floats."""
    w, x, y, z = matrix_to_quat(R).tolist()
    p = np.ascontiguousarray(p, dtype=float)
    px, py, pz = p.tolist()
    return p, (px, py, pz), (w, -x, -y, -z)


def _limit(label: str, value: float | None) -> float:
    """A step limit: None is none (``inf``), else a positive finite number."""
    if value is None:
        return math.inf
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise InvalidInput(f"{label} must be None or a positive finite number, got {value!r}")
    if not (np.isfinite(value) and value > 0):
        raise InvalidInput(f"{label} must be None or a positive finite number, got {value!r}")
    return float(value)
