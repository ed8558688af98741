"""Chipmunk's C API called from compiled code: one control step of a simulation (or of a batch
of them) as one compiled call.

pymunk keeps doing the dynamics; this module removes the Python around it by calling
Chipmunk's functions from numba by address (why by hand, and how: docs/physics.md, "How the
simulation modules work").

* :func:`advance`: one projected control step (write the bodies, step the space, read them
  back, project them with :func:`planar3p_gym.sim.projection.project_readout`, write them back);
  :func:`planar3p_gym.sim.chipmunk.advance_batch` over a batch; :func:`settle`;
* :data:`FUNCTIONS`, :func:`address`: the functions' and objects' addresses (run-time
  arguments, so the compiled code is cached);
* :data:`AVAILABLE`: ``False`` where pymunk's build lacks these functions (the simulation then
  steps through cffi);
* :data:`CLEARS_UPPER`, :func:`clear_upper`: ``vzeroupper`` before every call into Chipmunk.
"""

from __future__ import annotations

import math
import platform
from typing import Any, NamedTuple

import llvmlite.binding as llvm
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core import config as numba_config
from numba.extending import intrinsic

from planar3p_gym.machine.angles import wrap_angle
from planar3p_gym.sim.projection import (
    MAX_CLOSURE_ERROR,
    RECOVERY_OFFSET,
    project_in_place,
    project_readout,
    project_row,
)
from planar3p_gym.sim.recovery import excess_energy, recover

__all__ = [
    "AVAILABLE",
    "CLEARS_UPPER",
    "FUNCTIONS",
    "HANDLE_FIELDS",
    "BodyReadout",
    "address",
    "advance",
    "advance_batch",
    "body_readout",
    "clear_upper",
    "handle_row",
    "needs_recovery",
    "read_bodies",
    "recovered_step",
    "settle",
    "step_projected",
    "step_projected_viscous",
    "write_bodies",
    "write_forces",
]

#: The C signatures :data:`FUNCTIONS` are called with (as cffi spells them).
_SIGNATURES = {
    "cpSpaceStep": "void(*)(struct cpSpace *, double)",
    "cpConstraintGetImpulse": "double(*)(struct cpConstraint *)",
    "cpSpaceEachBody": "void(*)(struct cpSpace *, void(*)(struct cpBody *, void *), void *)",
    "pmSpaceBodyGetIteratorFuncBatched": "void(*)(struct cpBody *, void *)",
    "pmSpaceBodySetIteratorFuncBatched": "void(*)(struct cpBody *, void *)",
    "cpConstraintSetMaxForce": "void(*)(struct cpConstraint *, double)",
    "cpSpaceSetIterations": "void(*)(struct cpSpace *, int)",
}

try:
    from pymunk._chipmunk_cffi import ffi as _ffi
    from pymunk._chipmunk_cffi import lib as _cp

    AVAILABLE = (
        all(
            hasattr(_cp, name) and _ffi.getctype(_ffi.typeof(getattr(_cp, name))) == signature
            for name, signature in _SIGNATURES.items()
        )
        and _ffi.offsetof("pmFloatArray", "num") == 0
        and _ffi.sizeof(_ffi.typeof("pmFloatArray").fields[0][1].type) == 4
    )
except (ImportError, AttributeError, TypeError):  # pragma: no cover - other pymunk builds
    AVAILABLE = False


def address(pointer: Any) -> int:
    """The address of a cffi pointer (a pymunk object's ``_space``, ``_constraint``, ... or a
    ``pmFloatArray *``), as :func:`advance` takes it."""
    return int(_ffi.cast("uintptr_t", pointer))


class BodyReadout(NamedTuple):
    """pymunk's batch request for every body's position, angle, velocity and angular velocity
    of a space, and the array it reads into and writes from (:func:`body_readout`).  The
    handles keep the C structs and the memory alive."""

    memory: np.ndarray  #: the readout (float64): 6 numbers per body, in the space's body order
    array: Any  #: the ``pmFloatArray *`` over :attr:`memory`
    request: Any  #: the ``pmBatchedData *`` naming :attr:`array`
    ints: Any  #: the (empty) ``pmIntArray *`` the request also names


def body_readout(memory: np.ndarray, forces: bool = False) -> BodyReadout:
    """A batch request whose array is ``memory`` (a C-contiguous 1-D float64 array): of every
    body's position, angle, velocity and angular velocity, or with ``forces`` of its force and
    torque (``fx, fy, t``: a simulation's viscous friction, :func:`step_projected_viscous`).

    Its length is the array's room (``max``): pymunk grows a full array with ``realloc``,
    which memory numpy owns must never see, so it has to hold six (three) numbers for every
    body of the space, its own static body included.
    """
    if memory.dtype != np.float64 or memory.ndim != 1 or not memory.flags.c_contiguous:
        raise ValueError("a body readout's memory must be a C-contiguous 1-D float64 array")
    array = _ffi.new("pmFloatArray *")
    array.num, array.max = 0, memory.size
    array.arr = _ffi.cast("double *", memory.ctypes.data)
    ints = _ffi.gc(_cp.pmIntArrayNew(0), _cp.pmIntArrayFree)
    request = _ffi.new("pmBatchedData *")
    request.fields = (
        _cp.FORCE | _cp.TORQUE
        if forces
        else _cp.POSITION | _cp.ANGLE | _cp.VELOCITY | _cp.ANGULAR_VELOCITY
    )
    request.floatArray, request.intArray = array, ints
    return BodyReadout(memory, array, request, ints)


def handle_row(space: Any, servos: tuple, read: BodyReadout) -> np.ndarray:
    """A simulation's row of :data:`HANDLE_FIELDS` (addresses, uintp): its ``cpSpace *``, its
    three servos' ``cpConstraint *`` and the request and array of ``read``."""
    return np.array(
        [address(p) for p in (space, *servos, read.request, read.array)], dtype=np.uintp
    )


#: Addresses of ``cpSpaceStep``, ``cpConstraintGetImpulse``, ``cpSpaceEachBody``, the get and
#: set batch iterators, ``cpConstraintSetMaxForce`` and ``cpSpaceSetIterations``, in that order
#: (empty when not :data:`AVAILABLE`).
FUNCTIONS = (
    np.array([address(_ffi.addressof(_cp, name)) for name in _SIGNATURES], dtype=np.uintp)
    if AVAILABLE
    else np.zeros(0, dtype=np.uintp)
)
FUNCTIONS.flags.writeable = False

#: A simulation's row of handles for :func:`advance`: the addresses of its ``cpSpace``, its
#: three servos' ``cpConstraint``, its ``pmBatchedData`` request and that request's
#: ``pmFloatArray``.
HANDLE_FIELDS = ("space", "servo_1", "servo_2", "servo_3", "request", "array")

_VOID_P = ir.IntType(8).as_pointer()


def _pointer(builder: ir.IRBuilder, value: ir.Value) -> ir.Value:
    return builder.inttoptr(value, _VOID_P)


#: C types of :func:`_c_function`'s signatures: a pointer (passed as its address), a double, an
#: int, nothing.
_LLVM_TYPES = {"p": _VOID_P, "d": ir.DoubleType(), "i": ir.IntType(32), "v": ir.VoidType()}
_NUMBA_TYPES = {"p": types.uintp, "d": types.float64, "i": types.int32, "v": types.void}


def _compiles_avx() -> bool:
    """Whether numba compiles for an x86 CPU with AVX (the host's, unless numba's
    ``NUMBA_CPU_NAME`` names another; then only if ``NUMBA_CPU_FEATURES`` lists ``+avx``)."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    if numba_config.CPU_NAME and numba_config.CPU_NAME != "host":
        return "+avx" in (numba_config.CPU_FEATURES or "").split(",")
    return bool(llvm.get_host_cpu_features().get("avx", False))


#: Whether a call into Chipmunk from compiled code is preceded by ``vzeroupper``.  Compiled
#: code can leave the upper halves of the vector registers dirty where LLVM does not see it
#: (a 256-bit memory operand with a 128-bit destination), and Chipmunk's SSE code, with the
#: library's own ``pow`` and ``sincos``, then runs about four times slower until something
#: clears them (docs/physics.md, "How the simulation modules work").
CLEARS_UPPER = _compiles_avx()
_VZEROUPPER = ir.FunctionType(ir.VoidType(), [])


def _emit_clear_upper(builder: ir.IRBuilder) -> None:
    """Emit ``vzeroupper`` where :data:`CLEARS_UPPER` (nothing elsewhere)."""
    if CLEARS_UPPER:
        clear = cgutils.get_or_insert_function(
            builder.module, _VZEROUPPER, "llvm.x86.avx.vzeroupper"
        )
        builder.call(clear, [])


@intrinsic
def _clear_upper(typingctx: Any) -> Any:
    def codegen(context: Any, builder: ir.IRBuilder, signature: Any, args: Any) -> Any:
        _emit_clear_upper(builder)
        return context.get_dummy_value()

    return types.void(), codegen


@njit(cache=True)
def clear_upper() -> None:
    """``vzeroupper`` where :data:`CLEARS_UPPER`: what code that calls Chipmunk from Python
    (cffi) and times it needs after compiled code ran (a benchmark's floor)."""
    _clear_upper()


def _c_function(signature: str) -> Any:
    """An intrinsic ``call(fn, *args)`` that calls the C function at address ``fn`` with the
    C signature ``signature``, written ``result(parameters)`` in the letters of
    :data:`_LLVM_TYPES` (``"d(p)"``: ``double f(void *)``), after ``vzeroupper`` where
    :data:`CLEARS_UPPER`."""
    result, parameters = signature[0], signature[2:-1]
    sig = _NUMBA_TYPES[result](types.uintp, *(_NUMBA_TYPES[k] for k in parameters))
    fnty = ir.FunctionType(_LLVM_TYPES[result], [_LLVM_TYPES[k] for k in parameters])

    def codegen(context: Any, builder: ir.IRBuilder, signature: Any, values: Any) -> Any:
        f, *rest = values
        args = [
            _pointer(builder, v) if k == "p" else v for k, v in zip(parameters, rest, strict=True)
        ]
        _emit_clear_upper(builder)
        out = builder.call(builder.inttoptr(f, fnty.as_pointer()), args)
        return context.get_dummy_value() if result == "v" else out

    # (numba types an intrinsic by its typing function's own parameters: one per argument)
    typer = _TYPERS[len(parameters)](lambda: (sig, codegen))
    return intrinsic(typer)


_TYPERS = {
    1: lambda typed: lambda typingctx, fn, a: typed(),
    2: lambda typed: lambda typingctx, fn, a, b: typed(),
    3: lambda typed: lambda typingctx, fn, a, b, c: typed(),
}


_call_pd = _c_function("v(pd)")  # cpSpaceStep, cpConstraintSetMaxForce
_get_double = _c_function("d(p)")  # cpConstraintGetImpulse
_each_body = _c_function("v(ppp)")  # cpSpaceEachBody
_call_pi = _c_function("v(pi)")  # cpSpaceSetIterations


@intrinsic
def _store_int32(typingctx: Any, where: Any, value: Any) -> Any:
    """``*(int32_t *) where = value``."""
    sig = types.void(types.uintp, types.int32)

    def codegen(context: Any, builder: ir.IRBuilder, signature: Any, args: Any) -> Any:
        w, v = args
        builder.store(v, builder.inttoptr(w, ir.IntType(32).as_pointer()))
        return context.get_dummy_value()

    return sig, codegen


#: Columns of a readout row (``x, y, angle, vx, vy, w`` of the bodies in readout order:
#: platform, then slider, drive and leg of each leg) that hold the drives' ``vx``.
DRIVE_VX = (15, 33, 51)


@njit(cache=True)
def _pass(fns: np.ndarray, handles: np.ndarray, which: int) -> None:
    """One pass of a batch iterator (``which``: 3 get, 4 set) over the bodies of ``handles``'
    space, from the start of its array."""
    _store_int32(handles[5], np.int32(0))
    _each_body(fns[2], handles[0], fns[which], handles[4])


@njit(cache=True)
def read_bodies(fns: np.ndarray, handles: np.ndarray) -> None:
    """Read every body of the simulation of ``handles`` into its batch array (readout order:
    ``x, y, angle, vx, vy, w`` of each)."""
    _pass(fns, handles, 3)


@njit(cache=True)
def write_bodies(fns: np.ndarray, handles: np.ndarray) -> None:
    """Write every body of the simulation of ``handles`` from its batch array."""
    _pass(fns, handles, 4)


@njit(cache=True)
def write_forces(fns: np.ndarray, handles: np.ndarray, force_handles: np.ndarray) -> None:
    """Write every body's force and torque (until the next physics step, which clears them)
    from the array of the force request ``force_handles`` (its ``pmBatchedData *`` and
    ``pmFloatArray *``; :func:`body_readout` with ``forces``)."""
    _store_int32(force_handles[1], np.int32(0))
    _each_body(fns[2], handles[0], fns[4], force_handles[0])


@njit(cache=True)
def advance(
    fns: np.ndarray,
    handles: np.ndarray,
    v0: float,
    v1: float,
    v2: float,
    h: float,
    substeps: int,
    readout: np.ndarray,
    forces: np.ndarray,
) -> None:
    """Hold the drive velocities ``v0, v1, v2`` (m/s) for ``substeps`` physics steps of ``h``
    (s) on the simulation of ``handles`` (:data:`HANDLE_FIELDS`) whose batch array is
    ``readout`` (its first 60 numbers): write every body (from ``readout``, with the new drive
    velocities), step, read every body back into ``readout``.  ``forces`` (6) receives the
    servos' summed impulses and their largest single-substep impulse (N s)."""
    _write_with_drives(fns, handles, readout, v0, v1, v2, forces)
    for _ in range(substeps):
        _step_and_sum(fns, handles, h, forces)
    read_bodies(fns, handles)


@njit(cache=True)
def _write_with_drives(
    fns: np.ndarray, handles: np.ndarray, readout: np.ndarray, v0: float, v1: float, v2: float,
    forces: np.ndarray,
) -> None:  # fmt: skip
    """Write every body from ``readout`` with the drive velocities ``v0, v1, v2`` (m/s), and
    zero the impulse sums ``forces`` (a step's start)."""
    readout[DRIVE_VX[0]] = v0
    readout[DRIVE_VX[1]] = v1
    readout[DRIVE_VX[2]] = v2
    write_bodies(fns, handles)
    forces[:] = 0.0


@njit(cache=True)
def _project_and_write(
    fns: np.ndarray, handles: np.ndarray, force_limit: float, readout: np.ndarray,
    consts: np.ndarray, setpoint_limit: float, forces: np.ndarray,
) -> tuple[np.ndarray, float]:  # fmt: skip
    """A step's end: project ``readout`` (a servo is saturated when its largest substep impulse
    reaches ``force_limit``, N s) and write the projected bodies back."""
    state, closure = project_in_place(
        readout, forces[3] >= force_limit, forces[4] >= force_limit, forces[5] >= force_limit,
        consts, setpoint_limit,
    )  # fmt: skip
    write_bodies(fns, handles)
    return state, closure


@njit(cache=True)
def _step_and_sum(fns: np.ndarray, handles: np.ndarray, h: float, forces: np.ndarray) -> None:
    """One physics step of ``h`` (s); adds the servos' impulses (N s) to ``forces[:3]`` and
    keeps their largest in ``forces[3:]``."""
    _call_pd(fns[0], handles[0], h)
    for i in range(3):
        j = _get_double(fns[1], handles[1 + i])
        forces[i] += j
        if j > forces[3 + i]:  # (not max(): a NaN impulse leaves the largest as it was)
            forces[3 + i] = j


@njit(cache=True)
def needs_recovery(start: np.ndarray, end: np.ndarray, closure: float, consts: np.ndarray) -> bool:
    """Whether a projected step from the readout ``start`` to ``end`` (closure error
    ``closure``, m) is to be taken again by the constrained dynamics: where the projector has
    its numbers (``consts``, :data:`~planar3p_gym.sim.projection.RECOVERY_OFFSET`), when the
    projection failed or the step made more mechanical energy beyond the servos' work
    (:func:`~planar3p_gym.sim.recovery.excess_energy`) than the slack in ``consts``
    (:data:`~planar3p_gym.sim.recovery.ENERGY_SLACK`)."""
    r = RECOVERY_OFFSET
    if consts.shape[0] <= r or consts[r] != 1.0:
        return False
    if not closure <= MAX_CLOSURE_ERROR:
        return True
    return excess_energy(start, end, consts[22], consts[r + 4 :]) > consts[r + 3]


@njit(cache=True)
def recovered_step(
    start: np.ndarray, v0: float, v1: float, v2: float, h: float, force_limit: float,
    consts: np.ndarray, setpoint_limit: float, forces: np.ndarray,
) -> tuple[bool, np.ndarray, np.ndarray, float]:  # fmt: skip
    """A control step whose projection failed, taken again from its start readout ``start``
    by the constrained dynamics (:func:`planar3p_gym.sim.recovery.recover`, with the numbers
    in the projector's ``consts`` from :data:`~planar3p_gym.sim.projection.RECOVERY_OFFSET`)
    and projected: ``(ok, bodies, state, closure)`` as
    :func:`~planar3p_gym.sim.projection.project_readout` gives them, with the servos'
    impulses in ``forces[:6]`` (N s; ``force_limit``, N s: a saturated servo's largest).
    ``ok`` False (``forces`` untouched) where the projector has no recovery numbers or no
    closed state results: the failed step then stands."""
    r = RECOVERY_OFFSET
    bodies = np.empty(60)
    if consts.shape[0] <= r or consts[r] != 1.0:
        return False, bodies, np.empty(23), math.inf
    out = np.empty(60)
    impulses = np.empty(6)
    if not recover(start, v0, v1, v2, consts[22], h, consts[r + 4 :], out, impulses):
        return False, bodies, np.empty(23), math.inf
    bodies, state, closure, _ = project_readout(
        out, impulses[3] >= force_limit, impulses[4] >= force_limit, impulses[5] >= force_limit,
        consts, setpoint_limit,
    )  # fmt: skip
    if not closure <= MAX_CLOSURE_ERROR:
        return False, bodies, state, math.inf
    forces[:6] = impulses
    return True, bodies, state, closure


@njit(cache=True)
def _rewarm(fns: np.ndarray, handles: np.ndarray, h: float, consts: np.ndarray) -> None:
    """After a recovered step written into the bodies (from the batch array): re-solve the
    joint impulses the solver warm-starts from, which the failed step left wrong, by one
    physics step of ``h`` (s) with the warm-start iterations, the bodies put back after it,
    the solver left at its own iterations (both in ``consts``,
    :data:`~planar3p_gym.sim.projection.RECOVERY_OFFSET`)."""
    r = RECOVERY_OFFSET
    _call_pi(fns[6], handles[0], np.int32(consts[r + 2]))
    _call_pd(fns[0], handles[0], h)
    write_bodies(fns, handles)
    _call_pi(fns[6], handles[0], np.int32(consts[r + 1]))


@njit(cache=True)
def _recover_and_write(
    fns: np.ndarray, handles: np.ndarray, start: np.ndarray, v0: float, v1: float, v2: float,
    h: float, force_limit: float, readout: np.ndarray, consts: np.ndarray,
    setpoint_limit: float, forces: np.ndarray, state: np.ndarray, closure: float,
) -> tuple[np.ndarray, float]:  # fmt: skip
    """A single simulation's step end (the projected ``state``, ``closure`` and bodies in
    ``readout``, from the step's ``start``): where it :func:`needs_recovery`, the recovered
    step (:func:`recovered_step`) written back and the solver re-warmed (:func:`_rewarm`),
    with ``forces[6]`` set to 1 where ``forces`` has room; else ``state``, ``closure``."""
    if not needs_recovery(start, readout, closure, consts):
        return state, closure
    ok, bodies, new_state, new_closure = recovered_step(
        start, v0, v1, v2, h, force_limit, consts, setpoint_limit, forces
    )
    if not ok:
        return state, closure
    readout[:60] = bodies
    write_bodies(fns, handles)
    _rewarm(fns, handles, h, consts)
    if forces.shape[0] > 6:
        forces[6] = 1.0
    return new_state, new_closure


@njit(cache=True)
def _viscous_forces(readout: np.ndarray, applied: np.ndarray, cs: float, cj: float) -> None:
    """The viscous friction forces of :meth:`Planar3PSim._apply_viscous` from the velocities in
    ``readout``, into ``applied`` (``fx, fy, t`` per body in readout order; 0 where that method
    sets nothing, as Chipmunk leaves every force after a step), with its operations in its
    order: ``-cs vx`` on each slider, ``-cj w_l - cj (w_l - w_p)`` on each leg and the sum of
    ``cj (w_l - w_p)`` on the platform (N, N m)."""
    applied[:30] = 0.0
    w_p = readout[5]
    for i in range(3):
        slider, leg = 1 + 3 * i, 3 + 3 * i
        if cs > 0.0:
            applied[3 * slider] = -cs * readout[6 * slider + 3]
        if cj > 0.0:
            w_l = readout[6 * leg + 5]
            applied[3 * leg + 2] = -cj * w_l - cj * (w_l - w_p)
            applied[2] += cj * (w_l - w_p)


@njit(cache=True)
def settle(
    fns: np.ndarray,
    handles: np.ndarray,
    constraints: np.ndarray,
    limits: np.ndarray,
    h: float,
    warm_iterations: int,
    iterations: int,
) -> None:
    """The end of a reset that moves the bodies (:meth:`Planar3PSim.reset`), with the bodies
    placed at rest from the batch array (which still holds them): clear every constraint's
    accumulated impulse by one solver step with every force limit at zero (the clamp leaves
    exactly zero), restore the limits (``limits``, N, of ``constraints``, their addresses),
    put the bodies back, solve the resting joint loads with ``warm_iterations`` solver
    iterations in one step of ``h`` (s), put the bodies back again, and leave the solver at
    ``iterations``."""
    for c in constraints:
        _call_pd(fns[5], c, 0.0)
    _call_pi(fns[6], handles[0], np.int32(1))
    _call_pd(fns[0], handles[0], h)
    for n in range(constraints.shape[0]):
        _call_pd(fns[5], constraints[n], limits[n])
    write_bodies(fns, handles)
    _call_pi(fns[6], handles[0], np.int32(warm_iterations))
    _call_pd(fns[0], handles[0], h)
    write_bodies(fns, handles)
    _call_pi(fns[6], handles[0], np.int32(iterations))


@njit(cache=True)
def step_projected(
    fns: np.ndarray,
    handles: np.ndarray,
    v0: float,
    v1: float,
    v2: float,
    h: float,
    substeps: int,
    force_limit: float,
    readout: np.ndarray,
    consts: np.ndarray,
    setpoint_limit: float,
    forces: np.ndarray,
) -> tuple[np.ndarray, float]:
    """One control step of a single projected simulation: read the bodies into ``readout``
    (they may have been moved since the last step), :func:`advance`, project the readout
    (:func:`~planar3p_gym.sim.projection.project_readout` with the projector's ``consts``; a
    servo is saturated when its largest substep impulse reaches ``force_limit``, N s) and
    write the projected bodies back.  Returns ``(state, closure_error)`` as
    :func:`~planar3p_gym.sim.projection.project_readout` does (theta not wrapped)."""
    read_bodies(fns, handles)
    start = readout[:60].copy()
    advance(fns, handles, v0, v1, v2, h, substeps, readout, forces)
    state, closure = _project_and_write(
        fns, handles, force_limit, readout, consts, setpoint_limit, forces
    )
    return _recover_and_write(
        fns, handles, start, v0, v1, v2, h, force_limit, readout, consts, setpoint_limit,
        forces, state, closure,
    )  # fmt: skip


@njit(cache=True)
def step_projected_viscous(
    fns: np.ndarray,
    handles: np.ndarray,
    force_handles: np.ndarray,
    v0: float,
    v1: float,
    v2: float,
    h: float,
    substeps: int,
    force_limit: float,
    readout: np.ndarray,
    consts: np.ndarray,
    setpoint_limit: float,
    forces: np.ndarray,
    applied: np.ndarray,
    cs: float,
    cj: float,
) -> tuple[np.ndarray, float]:
    """:func:`step_projected` of a machine with viscous friction (slider coefficient ``cs``,
    N s/m; joint coefficient ``cj``, N m s/rad): before each physics step the bodies are read
    and their viscous forces written (:func:`_viscous_forces`, through the force request of
    ``force_handles``: its ``pmBatchedData *`` and ``pmFloatArray *``, over ``applied``)."""
    read_bodies(fns, handles)
    start = readout[:60].copy()
    _write_with_drives(fns, handles, readout, v0, v1, v2, forces)
    for _ in range(substeps):
        read_bodies(fns, handles)
        _viscous_forces(readout, applied, cs, cj)
        write_forces(fns, handles, force_handles)
        _step_and_sum(fns, handles, h, forces)
    read_bodies(fns, handles)
    state, closure = _project_and_write(
        fns, handles, force_limit, readout, consts, setpoint_limit, forces
    )
    return _recover_and_write(
        fns, handles, start, v0, v1, v2, h, force_limit, readout, consts, setpoint_limit,
        forces, state, closure,
    )  # fmt: skip


@njit(cache=True)
def advance_batch(
    fns: np.ndarray,
    handles: np.ndarray,
    rows: np.ndarray,
    velocities: np.ndarray,
    h: float,
    substeps: int,
    force_limit: float,
    readouts: np.ndarray,
    consts: np.ndarray,
    setpoint_limit: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`advance` and the projection of the simulations ``rows`` of a batch (the native
    vector env's step): ``handles`` ``(N, 6)``, ``readouts`` ``(N, >= 60)`` (each row its
    simulation's batch array, authoritative: the bodies are written from it), ``velocities``
    ``(len(rows), 3)`` drive commands (m/s).

    Returns ``(forces (len(rows), 6), saturated (3, len(rows)), states (23, len(rows)),
    closure (len(rows),))``: the summed and largest impulses (N s), the saturation flags, the
    projected states (theta wrapped into ``(-pi, pi]``, as
    :class:`~planar3p_gym.sim.physics.SimState` holds it) and the closure errors (m); the
    projected bodies are left in ``readouts`` (and written at the next step)."""
    n = rows.shape[0]
    forces = np.empty((n, 6))
    saturated = np.empty((3, n), dtype=np.bool_)
    states = np.empty((23, n))
    closure = np.empty(n)
    for k in range(n):
        i = rows[k]
        readout = readouts[i]
        start = readout[:60].copy()
        v0, v1, v2 = velocities[k, 0], velocities[k, 1], velocities[k, 2]
        advance(fns, handles[i], v0, v1, v2, h, substeps, readout, forces[k])
        for d in range(3):
            saturated[d, k] = forces[k, 3 + d] >= force_limit
        project_row(
            readout, saturated[0, k], saturated[1, k], saturated[2, k], consts, setpoint_limit,
            states, closure, k,
        )  # fmt: skip
        if needs_recovery(start, readout, closure[k], consts):  # as a single simulation
            ok, bodies, state, err = recovered_step(
                start, v0, v1, v2, h, force_limit, consts, setpoint_limit, forces[k]
            )
            if ok:
                readout[:60] = bodies
                write_bodies(fns, handles[i])
                _rewarm(fns, handles[i], h, consts)
                for d in range(3):
                    saturated[d, k] = forces[k, 3 + d] >= force_limit
                state[8] = wrap_angle(state[8])
                states[:, k] = state
                closure[k] = err
    return forces, saturated, states, closure
