"""Warp kernels of the batched elements: ``vibrofriction.contact_averaged`` and
``vibrofriction.contact_feeder`` for MuJoCo Warp, one thread per (world, element).

A line-by-line port of ``plugin/cpp/plugins/contact_friction.cc`` (``SlidingVelocity``,
``TangentResponse``, ``ImplicitForce``, ``FeederMapForce``, ``Advance``),
``plugin/cpp/plugins/averaged_friction.cc`` (``AveragedTable::Evaluate``, the averaged force, its
Jacobian and ``SolveAveragedEndVelocity``) and ``plugin/cpp/laws/friction_law.{h,cc}``
(``VectorStickSlipForce``, ``SolveLinear``, ``PseudoInverseSolve``), in MuJoCo Warp's float32:
the tolerances the C++ takes in double are set to float32's resolution (``NEWTON_TOL`` ...).
"""
from __future__ import annotations

import warp as wp

# float32 counterparts of the C++ tolerances (double there): the Newton residual (1e-10 of the
# scale there), its step (1e-15), the bisections' width (1e-15), the across part below which
# u lies along the axis (1e-9), the forward difference at rest (1e-7)
NEWTON_TOL = wp.constant(2e-6)
NEWTON_STEP_TOL = wp.constant(1e-7)
BISECT_TOL = wp.constant(2e-7)
ALONG_TOL = wp.constant(1e-5)
FD_STEP = wp.constant(3e-4)
PI = wp.constant(3.141592653589793)

vec6 = wp.types.vector(length=6, dtype=float)


@wp.struct
class Tables:
    """Every element's table (contact_averaged) or map (contact_feeder), flat."""

    xi: wp.array(dtype=float)
    angle: wp.array(dtype=float)
    along: wp.array(dtype=float)
    across: wp.array(dtype=float)
    map_velocity: wp.array(dtype=float)
    map_force: wp.array(dtype=float)
    # per element: offsets and sizes
    xi_adr: wp.array(dtype=int)
    xi_num: wp.array(dtype=int)
    angle_adr: wp.array(dtype=int)
    angle_num: wp.array(dtype=int)
    table_adr: wp.array(dtype=int)
    map_adr: wp.array(dtype=int)
    map_num: wp.array(dtype=int)


@wp.struct
class Elements:
    """Per element: what it is, the bodies, its chain dofs; per (world, element): parameters."""

    feeder: wp.array(dtype=int)        # 1 contact_feeder, 0 contact_averaged
    support: wp.array(dtype=int)
    color: wp.array(dtype=int)
    chain_adr: wp.array(dtype=int)
    chain_num: wp.array(dtype=int)
    chain_dof: wp.array(dtype=int)
    chain_sign: wp.array(dtype=float)
    # (nworld, nelement)
    mu: wp.array2d(dtype=float)
    viscous: wp.array2d(dtype=float)
    static_ratio: wp.array2d(dtype=float)
    stribeck_velocity: wp.array2d(dtype=float)
    velocity_amplitude: wp.array2d(dtype=float)
    torsion_radius: wp.array2d(dtype=float)
    axis: wp.array2d(dtype=wp.vec3)    # in the support's frame, normalized
    helix_pitch: wp.array2d(dtype=float)  # contact_feeder's helix_pitch (0: along axis)


# ---- linear algebra (n = 2 or 3 in a 3 x 3) ---------------------------------------------------------

@wp.func
def solve_linear(n: int, A_in: wp.mat33, b: wp.vec3, tiny: float) -> wp.vec4:
    """SolveLinear<N>: Gaussian elimination with partial pivoting; [3] = 1 when solved."""
    a = A_in
    rhs = b
    x = wp.vec3(0.0)
    for col in range(n):
        pivot = col
        for r in range(col + 1, n):
            if wp.abs(a[r, col]) > wp.abs(a[pivot, col]):
                pivot = r
        if not (wp.abs(a[pivot, col]) > tiny):
            return wp.vec4(0.0, 0.0, 0.0, 0.0)
        if pivot != col:
            for j in range(n):
                t = a[pivot, j]
                a[pivot, j] = a[col, j]
                a[col, j] = t
            t = rhs[pivot]
            rhs[pivot] = rhs[col]
            rhs[col] = t
        for r in range(col + 1, n):
            factor = a[r, col] / a[col, col]
            for j in range(col, n):
                a[r, j] = a[r, j] - factor * a[col, j]
            rhs[r] = rhs[r] - factor * rhs[col]
    for ii in range(n):
        i = n - 1 - ii
        s = rhs[i]
        for j in range(i + 1, n):
            s -= a[i, j] * x[j]
        x[i] = s / a[i, i]
    return wp.vec4(x[0], x[1], x[2], 1.0)


@wp.func
def pseudo_inverse_solve(n: int, B: wp.mat33, b: wp.vec3, tiny: float) -> wp.vec3:
    """PseudoInverseSolve<N>: B^+ b for a symmetric positive semi-definite B (Jacobi)."""
    a = wp.mat33(0.0)
    q = wp.mat33(0.0)
    for i in range(n):
        for j in range(n):
            a[i, j] = 0.5 * (B[i, j] + B[j, i])
        q[i, i] = 1.0
    for sweep in range(50):
        off = float(0.0)
        total = float(0.0)
        for i in range(n):
            for j in range(n):
                if i == j:
                    total += a[i, j] * a[i, j]
                else:
                    off += a[i, j] * a[i, j]
        if off <= 1e-30 * (total + off):
            break
        for i in range(n):
            for j in range(i + 1, n):
                if a[i, j] != 0.0:
                    theta = 0.5 * wp.atan2(2.0 * a[i, j], a[j, j] - a[i, i])
                    c = wp.cos(theta)
                    s = wp.sin(theta)
                    for k in range(n):
                        ki = a[k, i]
                        kj = a[k, j]
                        a[k, i] = c * ki - s * kj
                        a[k, j] = s * ki + c * kj
                    for k in range(n):
                        ik = a[i, k]
                        jk = a[j, k]
                        a[i, k] = c * ik - s * jk
                        a[j, k] = s * ik + c * jk
                    for k in range(n):
                        ki = q[k, i]
                        kj = q[k, j]
                        q[k, i] = c * ki - s * kj
                        q[k, j] = s * ki + c * kj
    x = wp.vec3(0.0)
    for k in range(n):
        if a[k, k] > tiny:
            projection = float(0.0)
            for i in range(n):
                projection += q[i, k] * b[i]
            for i in range(n):
                x[i] = x[i] + q[i, k] * projection / a[k, k]
    return x


@wp.func
def norm_n(n: int, v: wp.vec3) -> float:
    """The Euclidean norm of the first n components of v."""
    s = float(0.0)
    for i in range(n):
        s += v[i] * v[i]
    return wp.sqrt(s)


@wp.func
def end_velocity(n: int, lam: float, B: wp.mat33, v_free: wp.vec3) -> wp.vec3:
    """The end-of-step velocity u under the force lam u: (I + lam B) u = v_free on the first n
    components (stick_slip's bisection on lam); v_free where the system is singular."""
    A = wp.mat33(0.0)
    for i in range(n):
        for j in range(n):
            A[i, j] = lam * B[i, j]
        A[i, i] = A[i, i] + 1.0
    x = solve_linear(n, A, v_free, 0.0)
    if x[3] == 0.0:
        return v_free
    return wp.vec3(x[0], x[1], x[2])


@wp.func
def stick_slip(n: int, level: float, static_ratio: float, stribeck_velocity: float,
               viscous: float, v: wp.vec3, v_free: wp.vec3, B: wp.mat33) -> wp.vec3:
    """VectorStickSlipForce<N> (rigid Coulomb with stick) for n = 2 or 3; level = mu F_N."""
    trace = float(0.0)
    diagonal = int(1)
    for i in range(n):
        trace += B[i, i]
        for j in range(n):
            if i != j and B[i, j] != 0.0:
                diagonal = 0
    scale = float(1.0)
    for i in range(n):
        scale *= trace
    det = B[0, 0] * B[1, 1] - B[0, 1] * B[1, 0]
    if n == 3:
        det = wp.determinant(B)
    invertible = det > 1e-12 * scale
    stick = wp.vec3(0.0)
    if diagonal == 1:
        for i in range(n):
            if B[i, i] > 1e-12 * trace:
                stick[i] = v_free[i] / B[i, i]
    else:
        solved = float(0.0)
        if invertible:
            x = solve_linear(n, B, v_free, 0.0)
            solved = x[3]
            stick = wp.vec3(x[0], x[1], x[2])
        if solved == 0.0:
            stick = pseudo_inverse_solve(n, B, v_free, 1e-12 * trace)
    stick_norm = norm_n(n, stick)
    if stick_norm <= static_ratio * level:
        return stick
    speed = norm_n(n, v)
    kinetic = level
    if static_ratio != 1.0:
        ratio = speed / stribeck_velocity
        kinetic *= 1.0 + (static_ratio - 1.0) * wp.exp(-ratio * ratio)
    direction = stick / stick_norm
    moving = int(0)
    for i in range(n):
        if v_free[i] != 0.0:
            moving += 1
    one_axis = moving <= 1 and diagonal == 1
    if (not one_axis) and (not (diagonal == 1 and not invertible)) and kinetic > 0.0:
        b_mean = wp.max(trace / float(n), 1e-30)
        lo = float(0.0)
        hi = kinetic / (b_mean * wp.max(stick_norm - kinetic, 1e-30 * stick_norm))
        for k in range(200):
            u = end_velocity(n, hi, B, v_free)
            if hi * norm_n(n, u) >= kinetic:
                break
            lo = hi
            hi *= 2.0
        for k in range(100):
            if not (hi - lo > BISECT_TOL * hi):
                break
            mid = 0.5 * (lo + hi)
            u = end_velocity(n, mid, B, v_free)
            if mid * norm_n(n, u) >= kinetic:
                hi = mid
            else:
                lo = mid
        u = end_velocity(n, hi, B, v_free)
        u_norm = norm_n(n, u)
        if u_norm > 0.0:
            direction = u / u_norm
    out = kinetic * direction + viscous * v
    if n == 2:
        out[2] = 0.0
    return out


# ---- the averaged table (averaged_friction.cc) --------------------------------------------------------

@wp.func
def locate(grid: wp.array(dtype=float), adr: int, n: int, x: float) -> wp.vec3:
    """Locate: (index, weight of index + 1, d weight / dx) on grid[adr : adr + n]."""
    if x <= grid[adr]:
        slope = float(0.0)
        if x == grid[adr]:
            slope = 1.0 / (grid[adr + 1] - grid[adr])
        return wp.vec3(0.0, 0.0, slope)
    if x >= grid[adr + n - 1]:
        slope = float(0.0)
        if x == grid[adr + n - 1]:
            slope = 1.0 / (grid[adr + n - 1] - grid[adr + n - 2])
        return wp.vec3(float(n - 2), 1.0, slope)
    lo = int(0)          # grid[lo] <= x < grid[hi]
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if grid[adr + mid] <= x:
            lo = mid
        else:
            hi = mid
    width = grid[adr + lo + 1] - grid[adr + lo]
    return wp.vec3(float(lo), (x - grid[adr + lo]) / width, 1.0 / width)


@wp.func
def evaluate(t: Tables, e: int, xi: float, angle: float) -> vec6:
    """AveragedTable::Evaluate: (f_along, f_across, d along/d xi, d along/d angle,
    d across/d xi, d across/d angle)."""
    li = locate(t.xi, t.xi_adr[e], t.xi_num[e], xi)
    lj = locate(t.angle, t.angle_adr[e], t.angle_num[e], angle)
    i = int(li[0])
    wi = li[1]
    j = int(lj[0])
    wj = lj[1]
    n = t.angle_num[e]
    base = t.table_adr[e]
    out = vec6(0.0)
    for k in range(2):
        v00 = float(0.0)
        v01 = float(0.0)
        v10 = float(0.0)
        v11 = float(0.0)
        if k == 0:
            v00 = t.along[base + i * n + j]
            v01 = t.along[base + i * n + j + 1]
            v10 = t.along[base + (i + 1) * n + j]
            v11 = t.along[base + (i + 1) * n + j + 1]
        else:
            v00 = t.across[base + i * n + j]
            v01 = t.across[base + i * n + j + 1]
            v10 = t.across[base + (i + 1) * n + j]
            v11 = t.across[base + (i + 1) * n + j + 1]
        a = v00 * (1.0 - wj) + v01 * wj
        b = v10 * (1.0 - wj) + v11 * wj
        out[k] = a * (1.0 - wi) + b * wi
        out[2 + 2 * k] = (b - a) * li[2]
        out[3 + 2 * k] = ((v01 - v00) * (1.0 - wi) + (v11 - v10) * wi) * lj[2]
    return out


@wp.func
def averaged_force(t: Tables, e: int, level: float, viscous: float, axis: wp.vec3, u: wp.vec3,
                   va: float) -> wp.vec3:
    """AveragedVectorForce<3>."""
    along = wp.dot(axis, u)
    across_dir = u - along * axis
    across = wp.length(across_dir)
    xi = wp.sqrt(along * along + across * across) / va
    angle = wp.atan2(across, along)
    f = evaluate(t, e, xi, angle)
    across_unit = wp.vec3(0.0)
    if across > 0.0:
        across_unit = across_dir / across
    return level * (f[0] * axis + f[1] * across_unit) + viscous * u


@wp.func
def averaged_jacobian(t: Tables, e: int, level: float, viscous: float, axis: wp.vec3,
                      u: wp.vec3, va: float) -> wp.mat33:
    """AveragedVectorForceJacobian<3> (the caller checks |u| > 1e-12 v_a)."""
    along = wp.dot(axis, u)
    ev = u - along * axis
    across = wp.length(ev)
    r2 = along * along + across * across
    r = wp.sqrt(r2)
    J = wp.mat33(0.0)
    if not (across > ALONG_TOL * r):
        angle = float(0.0)
        sign = float(1.0)
        if not (along > 0.0):
            angle = PI
            sign = -1.0
        f = evaluate(t, e, r / va, angle)
        bend = f[5] / along
        for i in range(3):
            for j in range(3):
                delta = float(0.0)
                if i == j:
                    delta = 1.0
                J[i, j] = level * (axis[i] * f[2] * sign * axis[j] / va +
                                   bend * (delta - axis[i] * axis[j])) + viscous * delta
        return J
    ev = ev / across
    xi = r / va
    angle = wp.atan2(across, along)
    f = evaluate(t, e, xi, angle)
    bend = f[1] / across
    for i in range(3):
        for j in range(3):
            d_xi = u[j] / (r * va)
            d_angle = (along * ev[j] - across * axis[j]) / r2
            grad_along = f[2] * d_xi + f[3] * d_angle
            grad_across = f[4] * d_xi + f[5] * d_angle
            delta = float(0.0)
            if i == j:
                delta = 1.0
            projector = delta - axis[i] * axis[j] - ev[i] * ev[j]
            J[i, j] = level * (axis[i] * grad_along + ev[i] * grad_across + bend * projector) + \
                viscous * delta
    return J


@wp.func
def solve_averaged(t: Tables, e: int, level: float, viscous: float, axis: wp.vec3, va: float,
                   B: wp.mat33, v_free: wp.vec3, u_start: wp.vec3) -> wp.vec3:
    """SolveAveragedEndVelocity<3>: u + B F(u) = v_free by Newton from u_start; returns F(u)."""
    scale = va + wp.length(v_free)
    tolerance = NEWTON_TOL * scale
    u = u_start
    force = averaged_force(t, e, level, viscous, axis, u, va)
    r = u - v_free + B @ force
    r_norm = wp.length(r)
    for it in range(50):
        if not (r_norm > tolerance):
            break
        J = wp.identity(n=3, dtype=float)
        if wp.length(u) > 1e-12 * va:
            J = J + B @ averaged_jacobian(t, e, level, viscous, axis, u, va)
        else:  # at rest: a forward difference
            h = FD_STEP * (va + wp.length(u))
            for col in range(3):
                up = u
                up[col] = up[col] + h
                rp = up - v_free + B @ averaged_force(t, e, level, viscous, axis, up, va)
                for i in range(3):
                    J[i, col] = (rp[i] - r[i]) / h
        x = solve_linear(3, J, -r, 1e-30)
        step = wp.vec3(x[0], x[1], x[2])
        if x[3] == 0.0:
            step = -r
        alpha = float(1.0)
        trial = u
        r_trial = r
        f_trial = force
        norm_trial = r_norm
        for k in range(30):
            trial = u + alpha * step
            f_trial = averaged_force(t, e, level, viscous, axis, trial, va)
            r_trial = trial - v_free + B @ f_trial
            norm_trial = wp.length(r_trial)
            if norm_trial < (1.0 - 1e-4 * alpha) * r_norm:
                break
            alpha *= 0.5
        if not (norm_trial < r_norm):
            break
        u = trial
        r = r_trial
        force = f_trial
        r_norm = norm_trial
        if alpha * wp.length(step) <= NEWTON_STEP_TOL * scale:
            break
    return force


# ---- the feeder map (contact_friction.cc, FeederMapForce) ---------------------------------------------

@wp.func
def feeder_force(t: Tables, e: int, mu: float, stribeck_velocity: float, load: float,
                 B: wp.mat33, v: wp.vec3, v_free: wp.vec3, spin: int) -> wp.vec3:
    """FeederMapForce, in the frame with x along the feeder's axis: the force along the axis,
    -phi load, from element e's map (phi where the map's velocity-force curve meets the step's
    response, linearly interpolated), then rigid Coulomb with stick across the axis (and, with
    spin = 1, in torsion) within the rest of the cone, sqrt(mu^2 - phi^2) load; returns (along,
    across, torsion), torsion 0 without spin."""
    adr = t.map_adr[e]
    n = t.map_num[e]
    gain = wp.max(B[0, 0], 0.0) * load
    h0 = t.map_velocity[adr] - v_free[0] - gain * t.map_force[adr]
    hn = t.map_velocity[adr + n - 1] - v_free[0] - gain * t.map_force[adr + n - 1]
    phi = float(0.0)
    if h0 >= 0.0:
        phi = t.map_force[adr]
    elif hn <= 0.0:
        phi = t.map_force[adr + n - 1]
    else:
        lo = int(0)
        hi = n - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if t.map_velocity[adr + mid] - v_free[0] - gain * t.map_force[adr + mid] < 0.0:
                lo = mid
            else:
                hi = mid
        h_lo = t.map_velocity[adr + lo] - v_free[0] - gain * t.map_force[adr + lo]
        h_hi = t.map_velocity[adr + hi] - v_free[0] - gain * t.map_force[adr + hi]
        s = -h_lo / (h_hi - h_lo)
        phi = t.map_force[adr + lo] + s * (t.map_force[adr + hi] - t.map_force[adr + lo])
    f0 = -load * phi
    rest = wp.sqrt(wp.max(mu * mu - phi * phi, 0.0)) * wp.max(load, 0.0)
    v2 = wp.vec3(v[1], 0.0, 0.0)
    free2 = wp.vec3(v_free[1] - B[1, 0] * f0, 0.0, 0.0)
    B2 = wp.mat33(0.0)
    B2[0, 0] = B[1, 1]
    if spin == 1:
        v2[1] = v[2]
        free2[1] = v_free[2] - B[2, 0] * f0
        B2[0, 1] = B[1, 2]
        B2[1, 0] = B[2, 1]
        B2[1, 1] = B[2, 2]
    f2 = stick_slip(2, rest, 1.0, stribeck_velocity, 0.0, v2, free2, B2)
    f = wp.vec3(f0, f2[0], 0.0)
    if spin == 1:
        f[2] = f2[1]
    return f


# ---- the step: rows of J, then the force (the passive callback) --------------------------------------

@wp.func
def column(cdof: wp.spatial_vector, sign: float, offset: wp.vec3) -> wp.spatial_vector:
    """mj_jac's column at the point: (translation, rotation), signed body - support."""
    rot = wp.vec3(cdof[0], cdof[1], cdof[2])
    lin = wp.vec3(cdof[3], cdof[4], cdof[5])
    trans = sign * (lin + wp.cross(rot, offset))
    r = sign * rot
    return wp.spatial_vector(trans[0], trans[1], trans[2], r[0], r[1], r[2])


@wp.func
def helix_tangent(origin: wp.vec3, rotation: wp.mat33, point: wp.vec3, pitch: float) -> wp.vec3:
    """HelixTangent: the upward unit tangent at point of the helix about the support's z axis
    (rise pitch per counter-clockwise turn); zero on the axis."""
    local = wp.transpose(rotation) @ (point - origin)
    radius = wp.sqrt(local[0] * local[0] + local[1] * local[1])
    if not (radius > 1e-9):
        return wp.vec3(0.0)
    up = float(-1.0)
    if pitch > 0.0:
        up = 1.0
    run = 2.0 * PI * radius
    length = wp.sqrt(run * run + pitch * pitch)
    along = wp.vec3(up * (-local[1] / radius) * run / length,
                    up * (local[0] / radius) * run / length, wp.abs(pitch) / length)
    return rotation @ along


@wp.func
def tangent1(normal: wp.vec3) -> wp.vec3:
    """The contact frame's first tangent: x (y where the normal lies near x) with its normal
    part removed, normalized; the second is normal x tangent1."""
    t1 = wp.vec3(1.0, 0.0, 0.0)
    if not (wp.abs(normal[0]) < 0.9):
        t1 = wp.vec3(0.0, 1.0, 0.0)
    t1 = t1 - wp.dot(t1, normal) * normal
    return wp.normalize(t1)


@wp.func
def sliding_velocity(el: Elements, e: int, world: int, point: wp.vec3, normal: wp.vec3,
                     rho: float, body_rootid: wp.array(dtype=int),
                     dof_bodyid: wp.array(dtype=int), qvel: wp.array2d(dtype=float),
                     cdof: wp.array2d(dtype=wp.spatial_vector),
                     subtree_com: wp.array2d(dtype=wp.vec3)) -> wp.vec4:
    """SlidingVelocity: element e's body relative to its support at the contact point, from
    its chain dofs: (the tangential velocity in world coordinates (m/s), rho times the spin
    about the normal (m/s))."""
    v = wp.vec3(0.0)
    w = wp.vec3(0.0)
    for k in range(el.chain_num[e]):
        i = el.chain_dof[el.chain_adr[e] + k]
        offset = point - subtree_com[world, body_rootid[dof_bodyid[i]]]
        c = column(cdof[world, i], el.chain_sign[el.chain_adr[e] + k], offset)
        v += wp.vec3(c[0], c[1], c[2]) * qvel[world, i]
        w += wp.vec3(c[3], c[4], c[5]) * qvel[world, i]
    u = v - wp.dot(v, normal) * normal
    return wp.vec4(u[0], u[1], u[2], rho * wp.dot(w, normal))


@wp.kernel
def rows_kernel(
    el: Elements,
    state: wp.array3d(dtype=float),
    body_rootid: wp.array(dtype=int),
    dof_bodyid: wp.array(dtype=int),
    cdof: wp.array2d(dtype=wp.spatial_vector),
    subtree_com: wp.array2d(dtype=wp.vec3),
    rows: wp.array3d(dtype=float),   # (3 ncolor, nworld, nv): J's rows, summed over a color
):
    """Per (world, element) in contact: the three rows of the contact Jacobian J on the chain
    dofs (tangent 1, tangent 2, rho times the spin about the normal), written to the rows of
    the element's color (elements of one color share no kinematic tree), for M^-1 J'."""
    world, e = wp.tid()
    if not (state[world, e, 4] > 0.0):
        return
    point = wp.vec3(state[world, e, 5], state[world, e, 6], state[world, e, 7])
    normal = wp.vec3(state[world, e, 8], state[world, e, 9], state[world, e, 10])
    rho = state[world, e, 11]
    t1 = tangent1(normal)
    t2 = wp.cross(normal, t1)
    base = 3 * el.color[e]
    for k in range(el.chain_num[e]):
        i = el.chain_dof[el.chain_adr[e] + k]
        offset = point - subtree_com[world, body_rootid[dof_bodyid[i]]]
        c = column(cdof[world, i], el.chain_sign[el.chain_adr[e] + k], offset)
        trans = wp.vec3(c[0], c[1], c[2])
        rows[base, world, i] = wp.dot(t1, trans)
        rows[base + 1, world, i] = wp.dot(t2, trans)
        rows[base + 2, world, i] = rho * wp.dot(normal, wp.vec3(c[3], c[4], c[5]))


@wp.func
def response_matrix(el: Elements, e: int, world: int, rows: wp.array3d(dtype=float),
                    solved: wp.array3d(dtype=float), dt: float):
    """B = dt J M^-1 J' on the element's chain dofs (3 x 3: the contact frame's two tangents
    and the spin), from J's rows and M^-1 J' (this element's colour's)."""
    base = 3 * el.color[e]
    B = wp.mat33(0.0)
    for r in range(3):
        for cc in range(3):
            s = float(0.0)
            for k in range(el.chain_num[e]):
                i = el.chain_dof[el.chain_adr[e] + k]
                s += rows[base + r, world, i] * solved[base + cc, world, i]
            B[r, cc] = dt * s
    return B


@wp.func
def element_force(el: Elements, tables: Tables, e: int, world: int, load: float, rho: float,
                  point: wp.vec3, t1: wp.vec3, t2: wp.vec3, B: wp.mat33, v: wp.vec3,
                  v_free: wp.vec3, xpos: wp.array2d(dtype=wp.vec3),
                  xmat: wp.array2d(dtype=wp.mat33)):
    """The element's friction (tangent 1, tangent 2, spin moment / rho; N) from its law: the
    feeder map (contact_feeder), the averaged table under vibration (contact_averaged), else
    rigid Coulomb with stick (with torsion where rho > 0)."""
    mu = el.mu[world, e]
    viscous = el.viscous[world, e]
    static_ratio = el.static_ratio[world, e]
    stribeck = el.stribeck_velocity[world, e]
    config_va = el.velocity_amplitude[world, e]
    feeder = el.feeder[e]
    va = float(0.0)
    if feeder == 0:
        va = config_va
    axis3 = wp.vec3(0.0)
    in_plane = float(0.0)
    if feeder == 1 or va > 0.0:
        axis = xmat[world, el.support[e]] @ el.axis[world, e]
        pitch = el.helix_pitch[world, e]
        if pitch != 0.0:
            axis = helix_tangent(xpos[world, el.support[e]], xmat[world, el.support[e]], point,
                                 pitch)
        axis3 = wp.vec3(wp.dot(axis, t1), wp.dot(axis, t2), 0.0)
        in_plane = wp.sqrt(axis3[0] * axis3[0] + axis3[1] * axis3[1])
        va *= in_plane
        if in_plane > 0.0:
            axis3 = wp.vec3(axis3[0] / in_plane, axis3[1] / in_plane, 0.0)
    vibrating = va > 1e-9 * config_va
    spin = int(0)
    if rho > 0.0:
        spin = 1
    level = mu * load
    f3 = wp.vec3(0.0)
    if feeder == 1 and in_plane > 1e-6:
        R = wp.mat33(axis3[0], axis3[1], 0.0, -axis3[1], axis3[0], 0.0, 0.0, 0.0, 1.0)
        Br = R @ B @ wp.transpose(R)
        fr = feeder_force(tables, e, mu, stribeck, load, Br, R @ v, R @ v_free, spin)
        f3 = wp.transpose(R) @ fr
    elif vibrating:
        f3 = solve_averaged(tables, e, level, viscous, axis3, va, B, v_free, v)
    elif spin == 1:
        f3 = stick_slip(3, level, static_ratio, stribeck, viscous, v, v_free, B)
    else:
        B2 = wp.mat33(0.0)
        B2[0, 0] = B[0, 0]
        B2[0, 1] = B[0, 1]
        B2[1, 0] = B[1, 0]
        B2[1, 1] = B[1, 1]
        f3 = stick_slip(2, level, static_ratio, stribeck, viscous, v, v_free, B2)
        f3[2] = 0.0
    return f3


@wp.kernel
def force_kernel(
    el: Elements,
    tables: Tables,
    state: wp.array3d(dtype=float),
    timestep: wp.array(dtype=float),
    body_rootid: wp.array(dtype=int),
    dof_bodyid: wp.array(dtype=int),
    qvel: wp.array2d(dtype=float),
    cdof: wp.array2d(dtype=wp.spatial_vector),
    subtree_com: wp.array2d(dtype=wp.vec3),
    xpos: wp.array2d(dtype=wp.vec3),
    xmat: wp.array2d(dtype=wp.mat33),
    rows: wp.array3d(dtype=float),
    solved: wp.array3d(dtype=float),  # M^-1 rows
    # out
    qfrc_passive: wp.array2d(dtype=float),
    u_start: wp.array2d(dtype=wp.vec4),
    response: wp.array2d(dtype=wp.vec4),
    known: wp.array2d(dtype=int),
    sensor: wp.array3d(dtype=float),
):
    """The passive-force hook, per (world, element): this step's friction force.

    With B = dt J M^-1 J' and the sliding velocity predicted from the other forces, the
    element's law gives the force: the feeder map (contact_feeder), the averaged table under
    vibration (contact_averaged), else rigid Coulomb with stick (with torsion where rho > 0).
    Adds its generalized force to qfrc_passive, keeps the start velocity and the response
    B f for advance_kernel, and fills the sensor; nothing without a contact load.
    """
    world, e = wp.tid()
    known[world, e] = 0
    for k in range(10):
        sensor[world, e, k] = 0.0
    load = state[world, e, 4]
    if not (load > 0.0):
        return
    sensor[world, e, 8] = load
    dt = timestep[world % timestep.shape[0]]
    point = wp.vec3(state[world, e, 5], state[world, e, 6], state[world, e, 7])
    normal = wp.vec3(state[world, e, 8], state[world, e, 9], state[world, e, 10])
    rho = state[world, e, 11]
    u = sliding_velocity(el, e, world, point, normal, rho, body_rootid, dof_bodyid, qvel, cdof,
                         subtree_com)
    t1 = tangent1(normal)
    t2 = wp.cross(normal, t1)
    B = response_matrix(el, e, world, rows, solved, dt)
    other = wp.vec4(state[world, e, 12], state[world, e, 13], state[world, e, 14],
                    state[world, e, 15])
    ahead = u + dt * other
    if not (rho > 0.0):
        ahead[3] = 0.0
    u3 = wp.vec3(u[0], u[1], u[2])
    a3 = wp.vec3(ahead[0], ahead[1], ahead[2])
    v = wp.vec3(wp.dot(u3, t1), wp.dot(u3, t2), u[3])
    v_free = wp.vec3(wp.dot(a3, t1), wp.dot(a3, t2), ahead[3])
    f3 = element_force(el, tables, e, world, load, rho, point, t1, t2, B, v, v_free, xpos,
                       xmat)
    change = B @ f3
    f = f3[0] * t1 + f3[1] * t2
    resp = change[0] * t1 + change[1] * t2
    u_start[world, e] = u
    response[world, e] = wp.vec4(resp[0], resp[1], resp[2], change[2])
    known[world, e] = 1
    force = -(f - wp.dot(f, normal) * normal)
    torque = -rho * f3[2] * normal
    sensor[world, e, 0] = force[0]
    sensor[world, e, 1] = force[1]
    sensor[world, e, 2] = force[2]
    sensor[world, e, 3] = -rho * f3[2]
    sensor[world, e, 9] = wp.length(u)
    for k in range(el.chain_num[e]):
        i = el.chain_dof[el.chain_adr[e] + k]
        offset = point - subtree_com[world, body_rootid[dof_bodyid[i]]]
        c = column(cdof[world, i], el.chain_sign[el.chain_adr[e] + k], offset)
        generalized = wp.dot(wp.vec3(c[0], c[1], c[2]), force) + \
            wp.dot(wp.vec3(c[3], c[4], c[5]), torque)
        wp.atomic_add(qfrc_passive, world, i, generalized)


# ---- after the step: this step's contacts (Advance) --------------------------------------------------

@wp.func
def pair_element(pairs: wp.array(dtype=int), ngeom: int, g0: int, g1: int) -> int:
    """+(e + 1): geom[0] is the element's body's; -(e + 1): the support's; 0: none."""
    if g0 < 0 or g1 < 0:
        return 0
    return pairs[g0 * ngeom + g1]


@wp.kernel
def contact_sum_kernel(
    pairs: wp.array(dtype=int),
    ngeom: int,
    nacon: wp.array(dtype=int),
    contact_geom: wp.array(dtype=wp.vec2i),
    contact_pos: wp.array(dtype=wp.vec3),
    contact_frame: wp.array(dtype=wp.mat33),
    contact_efc_address: wp.array2d(dtype=int),
    contact_worldid: wp.array(dtype=int),
    efc_force: wp.array2d(dtype=float),
    njmax: int,
    sums: wp.array3d(dtype=float),   # (nworld, nelement, 8): F, F p (3), F n (3), F |p - p0|
    arm: int,                        # 0: the sums of F, F p, F n; 1: the arm (p0 known)
):
    """Per contact after the step: for a contact between an element's body and its support with
    a positive normal force F (N), add to that element's sums (arm 0) F, F p and F n, the
    normal signed to point from the support to the body, or (arm 1, once the point
    p0 = sum F p / sum F is known) F |p - p0|, for the torsion arm."""
    c = wp.tid()
    if c >= nacon[0]:
        return
    adr = contact_efc_address[c, 0]
    if adr < 0 or adr >= njmax:
        return
    g = contact_geom[c]
    code = pair_element(pairs, ngeom, g[0], g[1])
    if code == 0:
        return
    world = contact_worldid[c]
    frc = efc_force[world, adr]
    if not (frc > 0.0):
        return
    e = code - 1
    sign = float(-1.0)
    if code < 0:
        e = -code - 1
        sign = 1.0
    p = contact_pos[c]
    if arm == 0:
        n = contact_frame[c][0]
        wp.atomic_add(sums, world, e, 0, frc)
        for k in range(3):
            wp.atomic_add(sums, world, e, 1 + k, frc * p[k])
            wp.atomic_add(sums, world, e, 4 + k, sign * frc * n[k])
    else:
        total = sums[world, e, 0]
        p0 = wp.vec3(sums[world, e, 1], sums[world, e, 2], sums[world, e, 3]) / total
        wp.atomic_add(sums, world, e, 7, frc * wp.length(p - p0))


@wp.kernel
def advance_kernel(
    el: Elements,
    sums: wp.array3d(dtype=float),
    timestep: wp.array(dtype=float),
    body_rootid: wp.array(dtype=int),
    dof_bodyid: wp.array(dtype=int),
    qvel: wp.array2d(dtype=float),
    cdof: wp.array2d(dtype=wp.spatial_vector),
    subtree_com: wp.array2d(dtype=wp.vec3),
    u_start: wp.array2d(dtype=wp.vec4),
    response: wp.array2d(dtype=wp.vec4),
    known: wp.array2d(dtype=int),
    state: wp.array3d(dtype=float),
):
    """Advance, per (world, element) after the step: this step's contact into the state: the
    normal load (N), the force-weighted point, the unit normal, the torsion arm rho (m; the
    config's, else the force-weighted distance from the point), and the rate of change of the
    sliding velocity due to the other forces, for the next step's prediction; without contact
    the state is zeroed."""
    world, e = wp.tid()
    total = sums[world, e, 0]
    normal = wp.vec3(sums[world, e, 4], sums[world, e, 5], sums[world, e, 6])
    length = wp.length(normal)
    if not (total > 0.0) or not (length > 0.0):
        for k in range(16):
            state[world, e, k] = 0.0
        return
    normal = normal / length
    point = wp.vec3(sums[world, e, 1], sums[world, e, 2], sums[world, e, 3]) / total
    rho = el.torsion_radius[world, e]
    if rho == 0.0:
        rho = sums[world, e, 7] / total
        if rho < 1e-12:
            rho = 0.0
    state[world, e, 4] = total
    for k in range(3):
        state[world, e, 5 + k] = point[k]
        state[world, e, 8 + k] = normal[k]
    state[world, e, 11] = rho
    dt = timestep[world % timestep.shape[0]]
    u = sliding_velocity(el, e, world, point, normal, rho, body_rootid, dof_bodyid, qvel, cdof,
                         subtree_com)
    other = wp.vec4(0.0)
    if known[world, e] == 1:
        other = (u + response[world, e] - u_start[world, e]) / dt
    if not (rho > 0.0):
        other[3] = 0.0
    for k in range(4):
        state[world, e, 12 + k] = other[k]
