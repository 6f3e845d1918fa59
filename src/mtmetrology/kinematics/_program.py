"""The kinematic chain as a straight-line program over trials, for the compiled backend.

The chain's two passes (:mod:`mtmetrology.kinematics.chain`) are written on the sparse
entries of :mod:`mtmetrology.kinematics._sparse3`: ZERO, ONE, floats and arrays.  Run with
the readings of the *poses* as arrays of shape ``(n_poses,)`` and the error parameters as
:class:`Register` objects, the same code performs every pose-only operation at once in
numpy (nominal trigonometry, basis values, nominal motions: once per pose, shared by all
trials) and records every operation that involves a parameter as one instruction of a
:class:`Program`.  The program is then run, pose by pose, on blocks of trials by the
compiled kernel (:mod:`mtmetrology.kinematics._kernel`): no temporary arrays, one pass
over the output.

Instructions are rows ``(code, dest, a, b, c)`` of an integer array; ``a``, ``b`` are
registers, ``c`` a register or a column of the per-pose table ``S``.  Registers
``0 … n_params−1`` hold the error parameters of the current trials.  After recording,
three classic passes keep the program short: fusion of a product into the sum that
uses it (``x + s·y``, ``x ± y·z``), removal of instructions nothing reads, and register
reuse by liveness, so that a block of trials stays in the CPU cache.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.kinematics import _sparse3 as s3

# Instruction codes (the kernel's switch).
ADD_RR, SUB_RR, MUL_RR, ADD_RS, MUL_RS, NEG = range(6)
FMA_RS, FMA_RR, FMS_RR, STORE_R, STORE_NEG, STORE_S = range(6, 12)
#: Output selectors of the store instructions (``b`` field).
POSITION, JACOBIAN = 0, 1


def _scalar_value(x) -> float | None:
    """The float of a constant operand, None for an array operand."""
    if isinstance(x, np.ndarray):
        return float(x) if x.ndim == 0 else None
    return float(x)


class Register:
    """A per-trial value of a :class:`Program`: arithmetic with it records instructions.

    ``__array_ufunc__ = None`` makes numpy hand ``array op register`` to the register's
    reflected method instead of building an object array.
    """

    __array_ufunc__ = None
    __slots__ = ("index", "program")

    def __init__(self, program: Program, index: int):
        self.program = program
        self.index = index

    def __add__(self, other):
        p = self.program
        if isinstance(other, Register):
            return p.emit(ADD_RR, self.index, other.index)
        if _scalar_value(other) == 0.0:
            return self
        return p.emit(ADD_RS, self.index, 0, p.column(other))

    __radd__ = __add__

    def __neg__(self):
        return self.program.emit(NEG, self.index)

    def __sub__(self, other):
        if isinstance(other, Register):
            return self.program.emit(SUB_RR, self.index, other.index)
        return self + (-other)

    def __rsub__(self, other):
        return (-self) + other

    def __mul__(self, other):
        p = self.program
        if isinstance(other, Register):
            return p.emit(MUL_RR, self.index, other.index)
        value = _scalar_value(other)
        if value == 1.0:
            return self
        if value == -1.0:
            return -self
        return p.emit(MUL_RS, self.index, 0, p.column(other))

    __rmul__ = __mul__


class Program:
    """A straight-line program over blocks of trials, recorded by :class:`Register` arithmetic.

    Parameters
    ----------
    n_poses : int
        Number of poses; every array operand has shape ``(n_poses,)``.
    n_inputs : int
        Number of input registers (the error parameters).
    """

    def __init__(self, n_poses: int, n_inputs: int):
        self.n_poses = n_poses
        self.n_inputs = n_inputs
        self.n_registers = n_inputs
        self.instructions: list[list[int]] = []
        self._columns: list[np.ndarray | float] = []
        self._column_of: dict = {}

    def inputs(self) -> list[Register]:
        return [Register(self, j) for j in range(self.n_inputs)]

    def column(self, value) -> int:
        """Column of the per-pose table holding ``value`` (array (n_poses,) or constant)."""
        constant = _scalar_value(value)
        key = ("c", constant) if constant is not None else ("a", id(value))
        if key not in self._column_of:
            self._column_of[key] = len(self._columns)
            # the array is kept alive, so its id cannot be reused by another one
            self._columns.append(constant if constant is not None else value)
        return self._column_of[key]

    def emit(self, code: int, a: int = 0, b: int = 0, c: int = 0) -> Register:
        dest = self.n_registers
        self.n_registers += 1
        self.instructions.append([code, dest, a, b, c])
        return Register(self, dest)

    def store(self, output: int, column: int, value) -> None:
        """Write ``value`` (register, array or constant; ZERO/ONE of _sparse3 as 0/1)."""
        if isinstance(value, Register):
            self.instructions.append([STORE_R, column, value.index, output, 0])
            return
        if value is s3.ZERO or value is s3.ONE:
            value = 0.0 if value is s3.ZERO else 1.0
        self.instructions.append([STORE_S, column, 0, output, self.column(value)])

    # ------------------------------------------------------------------ finishing
    def table(self) -> np.ndarray:
        """The per-pose table ``S``, shape (n_poses, n_columns), C order."""
        out = np.empty((self.n_poses, max(len(self._columns), 1)))
        for k, col in enumerate(self._columns):
            out[:, k] = col
        return out

    def compile(self) -> tuple[np.ndarray, int]:
        """Fused, pruned, register-allocated instructions (n, 5) and the register count."""
        ops = _fuse(self.instructions, self)
        ops = _prune(ops)
        return _allocate(ops, self.n_inputs)


_READS = {
    ADD_RR: (2, 3),
    SUB_RR: (2, 3),
    MUL_RR: (2, 3),
    ADD_RS: (2,),
    MUL_RS: (2,),
    NEG: (2,),
    FMA_RS: (2, 3),
    FMA_RR: (2, 3, 4),
    FMS_RR: (2, 3, 4),
    STORE_R: (2,),
    STORE_NEG: (2,),
    STORE_S: (),
}

_STORES = (STORE_R, STORE_NEG, STORE_S)


def _fuse(instructions: list[list[int]], program: Program) -> list[list[int]]:
    """Fold single-use products and negations into the sums that read them."""
    ops = [list(op) for op in instructions]
    uses: dict[int, int] = {}
    for op in ops:
        for f in _READS[op[0]]:
            uses[op[f]] = uses.get(op[f], 0) + 1
    define = {op[1]: op for op in ops if op[0] not in _STORES}

    def single(reg: int, *codes: int):
        op = define.get(reg)
        return op if op is not None and op[0] in codes and uses.get(reg) == 1 else None

    def negated(col: int) -> int:
        return program.column(-np.asarray(program._columns[col]))

    alias: dict[int, int] = {}  # register -> the register it equals
    for op in ops:
        for f in _READS[op[0]]:
            op[f] = alias.get(op[f], op[f])
        if op[0] == NEG and (src := single(op[2], NEG)):  # −(−y) = y
            alias[op[1]] = src[2]
            op[0] = src[0] = -1
            continue
        if op[0] == NEG and (src := single(op[2], MUL_RS)):  # −(y·s) = y·(−s)
            op[:] = [MUL_RS, op[1], src[2], 0, negated(src[4])]
            src[0] = -1
        if op[0] == SUB_RR and (src := single(op[3], NEG)):  # x − (−y) = x + y
            op[:] = [ADD_RR, op[1], op[2], src[2], 0]
            src[0] = -1
        if op[0] == ADD_RR:
            for x, y in ((op[2], op[3]), (op[3], op[2])):
                if src := single(y, NEG):  # x + (−y) = x − y
                    op[:] = [SUB_RR, op[1], x, src[2], 0]
                elif src := single(y, MUL_RS):
                    op[:] = [FMA_RS, op[1], x, src[2], src[4]]
                elif src := single(y, MUL_RR):
                    op[:] = [FMA_RR, op[1], x, src[2], src[3]]
                else:
                    continue
                src[0] = -1
                break
        if op[0] == SUB_RR:
            if src := single(op[3], MUL_RR):
                op[:] = [FMS_RR, op[1], op[2], src[2], src[3]]
                src[0] = -1
            elif src := single(op[3], MUL_RS):
                op[:] = [FMA_RS, op[1], op[2], src[2], negated(src[4])]
                src[0] = -1
        if op[0] == STORE_R and (src := single(op[2], NEG)):  # store −y
            op[:] = [STORE_NEG, op[1], src[2], op[3], 0]
            src[0] = -1
    return [op for op in ops if op[0] >= 0]


def _prune(ops: list[list[int]]) -> list[list[int]]:
    """Drop instructions whose result nothing stores (backwards liveness)."""
    live: set[int] = set()
    kept = []
    for op in reversed(ops):
        if op[0] in _STORES or op[1] in live:
            kept.append(op)
            live.update(op[f] for f in _READS[op[0]])
    return kept[::-1]


def _allocate(ops: list[list[int]], n_inputs: int) -> tuple[np.ndarray, int]:
    """Rename registers so that a register is reused once its value is dead.

    Input registers (the parameters) stay put: they are loaded once per block of
    trials and read at every pose.
    """
    last: dict[int, int] = {}
    for i, op in enumerate(ops):
        for f in _READS[op[0]]:
            last[op[f]] = i
    rename = {j: j for j in range(n_inputs)}
    free: list[int] = []
    n_registers = n_inputs
    out = np.zeros((len(ops), 5), dtype=np.int64)
    for i, op in enumerate(ops):
        row = list(op)
        for f in _READS[op[0]]:
            row[f] = rename[op[f]]
        if op[0] not in _STORES:
            if free:
                rename[op[1]] = free.pop()
            else:
                rename[op[1]] = n_registers
                n_registers += 1
            row[1] = rename[op[1]]
        # operands are freed after the destination is chosen: a destination never
        # overlaps an operand, so the compiler's run-time overlap check lets the
        # vectorised loop run
        for f in _READS[op[0]]:
            reg = op[f]
            if reg >= n_inputs and last.get(reg) == i and rename[reg] not in free:
                free.append(rename[reg])
        out[i] = row
    return out, n_registers
