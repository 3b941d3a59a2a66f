"""The batched twin on MuJoCo Warp: a scene with contact_averaged / contact_feeder elements,
stepped for many worlds at once, the elements applied through MuJoCo Warp's passive-force hook
(``Model.callback.passive``, which adds to ``Data.qfrc_passive`` as the C++ plugins do) and their
state carried per world.

Each step (as the C++ plugin inside ``mj_step``): MuJoCo Warp's forward pass calls the hook
after its passive forces, where the element factors M (this step's), solves M^-1 J' for its
rows, and adds its force; after the integration the twin sums each world's contacts of the
step into the element's state (``Advance``).
"""
from __future__ import annotations

import numpy as np
import mujoco
import warp as wp
import mujoco_warp as mjw

from ..params import ParameterError
from . import kernels as k
from .scene import (PARAMETERS, SENSOR_SIZE, STATE_SIZE, chain, colors, surface_pairs,
                    twin_scene)


def _array(values, dtype, device):
    return wp.array(np.ascontiguousarray(values), dtype=dtype, device=device)


class BatchedTwin:
    """``nworld`` copies of ``scene`` (MJCF path or text, or an MjSpec) on MuJoCo Warp.

    ``twin.model`` is the scene without plugins (a plain ``mujoco.MjModel``),
    ``twin.mjw_model`` / ``twin.data`` MuJoCo Warp's model and data (``data.qpos`` ... are
    (nworld, n) Warp arrays; ``data.ctrl`` and ``data.xfrc_applied`` are the inputs),
    ``twin.elements`` the elements in the order of the scene's plugin instances.
    Per world and element parameters (``set_parameter``): PARAMETERS (the config keys mu,
    viscous, static_ratio, stribeck_velocity, velocity_amplitude, torsion_radius) and ``axis``.
    """

    def __init__(self, scene, nworld: int, *, data: mujoco.MjData | None = None,
                 nconmax: int | None = None, njmax: int | None = None, device=None):
        if not (isinstance(nworld, int) and nworld >= 1):
            raise ParameterError(f"nworld={nworld!r} must be a positive integer")
        twin = twin_scene(scene)
        self.scene = twin
        self.model = twin.model
        self.elements = twin.elements
        self.nworld = nworld
        self.device = wp.get_device(device)
        if not self.elements:
            raise ParameterError("batched twin: the scene has no vibrofriction.contact_averaged "
                                 "or vibrofriction.contact_feeder element")
        m = self.model
        if m.opt.integrator not in (mujoco.mjtIntegrator.mjINT_EULER,
                                    mujoco.mjtIntegrator.mjINT_IMPLICITFAST):
            raise ParameterError("batched twin: the elements need the Euler or implicitfast "
                                 "integrator (as the C++ plugins)")
        with wp.ScopedDevice(self.device):
            self.mjw_model = mjw.put_model(m)
            mjdata = data if data is not None else mujoco.MjData(m)
            if data is None:
                mujoco.mj_forward(m, mjdata)
            self.data = mjw.put_data(m, mjdata, nworld=nworld, nconmax=nconmax, njmax=njmax)
            self._build()
            self.mjw_model.callback.passive = self._passive
        self.import_plugin_state(None)

    # ---- construction ----------------------------------------------------------------------------

    def _build(self) -> None:
        m, device, nworld = self.model, self.device, self.nworld
        n = len(self.elements)
        chains = []
        for e in self.elements:
            chains.append(chain(m, m.body(e.body).id, m.body(e.support).id))
        color = colors(m, [dofs for dofs, _ in chains])
        self.ncolor = max(color) + 1
        adr = np.cumsum([0] + [len(d) for d, _ in chains])
        dofs = np.array([d for c, _ in chains for d in c] or [0], dtype=np.int32)
        signs = np.array([s for _, c in chains for s in c] or [0.0], dtype=np.float32)
        self._params = {name: np.tile([e.parameters[name] for e in self.elements], (nworld, 1))
                        .astype(np.float32) for name in PARAMETERS}
        self._axis = np.tile(np.array([e.axis for e in self.elements], dtype=np.float32),
                             (nworld, 1, 1))
        el = k.Elements()
        el.feeder = _array(np.array([e.feeder for e in self.elements], np.int32), int, device)
        el.support = _array(np.array([m.body(e.support).id for e in self.elements], np.int32),
                            int, device)
        el.color = _array(np.array(color, np.int32), int, device)
        el.chain_adr = _array(adr[:-1].astype(np.int32), int, device)
        el.chain_num = _array(np.diff(adr).astype(np.int32), int, device)
        el.chain_dof = _array(dofs, int, device)
        el.chain_sign = _array(signs, float, device)
        self._el = el
        self._upload_parameters()
        t = k.Tables()
        grids = {key: [] for key in ("xi", "angle", "along", "across", "map_velocity",
                                     "map_force")}
        # each element's offset (adr) and size (num) in the flat arrays
        offsets = {"xi_adr": ("xi", 0), "xi_num": ("xi", 1), "angle_adr": ("angle", 0),
                   "angle_num": ("angle", 1), "table_adr": ("along", 0),
                   "map_adr": ("map_velocity", 0), "map_num": ("map_velocity", 1)}
        offset_values = {key: [] for key in offsets}
        size = {key: 0 for key in grids}
        for e in self.elements:
            for key, (grid, is_num) in offsets.items():
                offset_values[key].append(len(getattr(e, grid)) if is_num else size[grid])
            for key in grids:
                values = getattr(e, key)
                grids[key].append(values)
                size[key] += len(values)
        for key, parts in grids.items():
            flat = np.concatenate(parts) if size[key] else np.zeros(1)
            setattr(t, key, _array(flat.astype(np.float32), float, device))
        for key, values in offset_values.items():
            setattr(t, key, _array(np.array(values, np.int32), int, device))
        self._tables = t
        # (geom, geom) -> +-(element + 1): the pairs whose contacts each element sums
        pairs = np.zeros(m.ngeom * m.ngeom, np.int32)
        for index, e in enumerate(self.elements):
            for g_body, g_support in surface_pairs(m, e):
                pairs[g_body * m.ngeom + g_support] = index + 1
                pairs[g_support * m.ngeom + g_body] = -(index + 1)
        self._pairs = _array(pairs, int, device)
        self._state = wp.zeros((nworld, n, STATE_SIZE), dtype=float, device=device)
        self._sums = wp.zeros((nworld, n, 8), dtype=float, device=device)
        self._u_start = wp.zeros((nworld, n), dtype=wp.vec4, device=device)
        self._response = wp.zeros((nworld, n), dtype=wp.vec4, device=device)
        self._known = wp.zeros((nworld, n), dtype=int, device=device)
        self._sensor = wp.zeros((nworld, n, SENSOR_SIZE), dtype=float, device=device)
        self._rows = wp.zeros((3 * self.ncolor, nworld, m.nv), dtype=float, device=device)
        self._solved = wp.zeros((3 * self.ncolor, nworld, m.nv), dtype=float, device=device)

    def _upload_parameters(self) -> None:
        for name in PARAMETERS:
            setattr(self._el, name, _array(self._params[name], float, self.device))
        self._el.axis = _array(self._axis, wp.vec3, self.device)

    # ---- parameters and state -----------------------------------------------------------------------

    def element_index(self, element) -> int:
        if isinstance(element, int):
            return element
        for index, e in enumerate(self.elements):
            if element in (e.name, e.body):
                return index
        raise ParameterError(f"no batched element named {element!r} (instances: "
                             f"{', '.join(e.name for e in self.elements)})")

    def set_parameter(self, name: str, values, element=None) -> None:
        """Set a parameter per world: ``values`` broadcasts to (nworld,) for one ``element``
        (its instance or body name, or index) or to (nworld, nelement) for all. ``axis``
        takes 3 numbers per world (the support's frame; normalized here)."""
        columns = slice(None) if element is None else self.element_index(element)
        if name == "axis":
            axis = np.asarray(values, dtype=float)
            norm = np.linalg.norm(axis, axis=-1, keepdims=True)
            if np.any(norm == 0):
                raise ParameterError("axis: not all 0")
            self._axis[:, columns] = axis / norm
        elif name in PARAMETERS:
            values = np.asarray(values, dtype=float)
            if name in ("mu", "viscous", "velocity_amplitude", "torsion_radius") and \
                    np.any(values < 0):
                raise ParameterError(f"{name} must be >= 0")
            if name == "static_ratio" and np.any(values < 1):
                raise ParameterError("static_ratio must be >= 1")
            if name == "stribeck_velocity" and np.any(values <= 0):
                raise ParameterError("stribeck_velocity must be > 0")
            if element is not None:
                values = np.broadcast_to(values, (self.nworld,))
            self._params[name][:, columns] = values
        else:
            raise ParameterError(f"unknown batched parameter {name!r}; use one of "
                                 f"{', '.join(PARAMETERS + ('axis',))}")
        self._upload_parameters()

    def parameter(self, name: str) -> np.ndarray:
        return self._axis.copy() if name == "axis" else self._params[name].copy()

    @property
    def state(self) -> np.ndarray:
        """(nworld, nelement, 16): each element's plugin_state (ContactState's layout)."""
        return self._state.numpy()

    def import_plugin_state(self, plugin_state) -> None:
        """Set every world's element state from an original model's ``MjData.plugin_state``
        (None: zeros, as after mj_resetData)."""
        state = np.zeros((self.nworld, len(self.elements), STATE_SIZE), np.float32)
        if plugin_state is not None:
            plugin_state = np.asarray(plugin_state, dtype=float)
            for index, adr in enumerate(self.scene.plugin_stateadr):
                state[:, index] = plugin_state[adr:adr + STATE_SIZE]
        wp.copy(self._state, _array(state, float, self.device))

    def load_mjdata(self, data: mujoco.MjData) -> None:
        """Every world from ``data`` of the original scene (with the plugins): positions,
        velocities, activations, controls, applied forces, warm start, time and the elements'
        plugin_state."""
        m = self.model
        host = mujoco.MjData(m)
        for field in ("qpos", "qvel", "act", "ctrl", "qfrc_applied", "xfrc_applied",
                      "qacc_warmstart", "mocap_pos", "mocap_quat"):
            getattr(host, field)[:] = getattr(data, field)
        host.time = data.time
        mujoco.mj_forward(m, host)
        with wp.ScopedDevice(self.device):
            fresh = mjw.put_data(m, host, nworld=self.nworld, nconmax=None,
                                 njmax=self.data.njmax, naconmax=self.data.naconmax)
            for field in ("qpos", "qvel", "act", "ctrl", "qfrc_applied", "xfrc_applied",
                          "qacc_warmstart", "mocap_pos", "mocap_quat", "time"):
                wp.copy(getattr(self.data, field), getattr(fresh, field))
        self.import_plugin_state(data.plugin_state)

    def sensor(self, element) -> np.ndarray:
        """(nworld, 10): vibrofriction.contact_sensor's values of ``element`` (instance or body
        name, or a contact_sensor's name): force (3, world), moment about n, z_t (3), theta, F_N,
        sliding speed; this step's force."""
        if isinstance(element, str) and element in self.scene.sensors:
            element = self.scene.sensors[element]
        return self._sensor.numpy()[:, self.element_index(element)]

    # ---- the step ---------------------------------------------------------------------------------

    def _passive(self, m, d) -> None:
        mjw.factor_m(m, d)  # this step's factor (MuJoCo Warp factors later in its forward pass)
        self._rows.zero_()
        dims = (self.nworld, len(self.elements))
        wp.launch(k.rows_kernel, dim=dims,
                  inputs=[self._el, self._state, m.body_rootid, m.dof_bodyid, d.cdof,
                          d.subtree_com], outputs=[self._rows])
        for row in range(3 * self.ncolor):
            mjw.solve_m(m, d, self._solved[row], self._rows[row])
        wp.launch(k.force_kernel, dim=dims,
                  inputs=[self._el, self._tables, self._state, m.opt.timestep, m.body_rootid,
                          m.dof_bodyid, d.qvel, d.cdof, d.subtree_com, d.xpos, d.xmat,
                          self._rows,
                          self._solved],
                  outputs=[d.qfrc_passive, self._u_start, self._response, self._known,
                           self._sensor])

    def _advance(self) -> None:
        m, d = self.mjw_model, self.data
        self._sums.zero_()
        for arm in (0, 1):
            wp.launch(k.contact_sum_kernel, dim=d.naconmax,
                      inputs=[self._pairs, self.model.ngeom, d.nacon, d.contact.geom,
                              d.contact.pos, d.contact.frame, d.contact.efc_address,
                              d.contact.worldid, d.efc.force, d.njmax, self._sums, arm])
        wp.launch(k.advance_kernel, dim=(self.nworld, len(self.elements)),
                  inputs=[self._el, self._sums, m.opt.timestep, m.body_rootid, m.dof_bodyid,
                          d.qvel, d.cdof, d.subtree_com, self._u_start, self._response,
                          self._known], outputs=[self._state])

    def step(self, nstep: int = 1) -> None:
        """``nstep`` steps of every world (mj_step with the C++ plugins, batched)."""
        with wp.ScopedDevice(self.device):
            for _ in range(nstep):
                mjw.step(self.mjw_model, self.data)
                self._advance()

    # ---- convenience -----------------------------------------------------------------------------

    def numpy(self, field: str) -> np.ndarray:
        """A field of the batched data as NumPy (e.g. "qpos", "qvel", "xpos")."""
        return getattr(self.data, field).numpy()


__all__ = ["BatchedTwin"]
