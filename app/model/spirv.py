"""Instruction counts of the lab's own shaders, read from their SPIR-V.

A program's final GLSL (the text the driver gets, app.pipeline.shaders.stage_texts) is
compiled by glslang for OpenGL (-G, unoptimised, with line information) and disassembled by
spirv-dis; this module parses the disassembly and counts, by one rule, the instructions of a
function or of one loop's iteration.  SPIR-V is the reproducible, vendor-neutral instruction
stream of the shader as written; a GPU compiler's output differs by its own optimisations,
which is one of the model's named assumptions (app.model.cost.ASSUMED).

The counting rule, per instruction, in four columns: `alu` (issue slots), `trans`
(transcendental ops), `idiv` (integer divisions and modulos) and `wred` (subgroup
reductions); the cost model prices the last two by its named assumptions
(app.model.cost.ASSUMED: an integer division's issue slots, a reduction's steps):

    arithmetic, compare, select, bit, conversion ops   1 a component of the result
    OpDot                                              1 a component of the operand
    matrix x vector                                    1 a row and column
    OpAll / OpAny                                      1 a component of the operand
    OpFDiv                                             a reciprocal (trans) and a multiply
    integer division, modulo                           1 idiv a component
    GLSL.std.450: sqrt, inversesqrt, exp, log, trig    1 trans a component
                  pow                                  2 trans (log, exp) and a multiply
                  normalize, length, distance          the dot product, 1 trans, the scale
                  min, max, abs, floor, fma, findLSB   1 a component (clamp, mix, step: 2)
    a load or store of a buffer, an image or shared    1 a 16-byte piece (a vec4 load each:
      memory; an atomic; a texel fetch                   the 96-byte light is 6)
    OpAccessChain into a buffer or shared memory       1 a dynamic index (its address)
    a conditional branch, a switch                     1
    a subgroup operation                               1 alu; a reduction or scan 1 wred
    OpFunctionCall                                     the callee's count (unless priced apart)
    free: loads, stores and access chains of locals, parameters, an invocation's globals and
      its built-in inputs (registers once compiled: REGISTERS), composite extract /
      construct / shuffle, copies, bitcasts, phis, labels,
      unconditional branches, merges, returns, barriers (counted by the figures, not timed)

Both sides of an if count (a wave whose lanes diverge runs both); a loop inside a counted
function counts its body once; an unknown opcode is an error, so the rule stays complete.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import UserError

GLSLANG_ARGS = ("-G", "--target-env", "spirv1.3", "--aml", "-g")
LINE_EXTENSION = "#extension GL_GOOGLE_cpp_style_line_directive : require"

# ---- the rule ---------------------------------------------------------------------------

_PER_COMPONENT = set("""
IAdd FAdd ISub FSub IMul FMul FNegate SNegate FMod FRem SRem
VectorTimesScalar MatrixTimesScalar
BitwiseAnd BitwiseOr BitwiseXor Not ShiftLeftLogical ShiftRightLogical ShiftRightArithmetic
BitCount BitFieldInsert BitFieldSExtract BitFieldUExtract BitReverse
IEqual INotEqual UGreaterThan SGreaterThan UGreaterThanEqual SGreaterThanEqual ULessThan
SLessThan ULessThanEqual SLessThanEqual FOrdEqual FUnordEqual FOrdNotEqual FUnordNotEqual
FOrdLessThan FUnordLessThan FOrdGreaterThan FUnordGreaterThan FOrdLessThanEqual
FUnordLessThanEqual FOrdGreaterThanEqual FUnordGreaterThanEqual
LogicalEqual LogicalNotEqual LogicalOr LogicalAnd LogicalNot Select IsNan IsInf
ConvertFToU ConvertFToS ConvertSToF ConvertUToF UConvert SConvert FConvert
DPdx DPdy Fwidth DPdxFine DPdyFine FwidthFine DPdxCoarse DPdyCoarse FwidthCoarse
""".split())
_PER_OPERAND = {"Dot", "All", "Any"}
_MATRIX = {"MatrixTimesVector": 2, "VectorTimesMatrix": 1}     # the operand: the vector
_INT_DIVISION = {"UDiv", "SDiv", "UMod", "SMod"}
_FREE = set("""
Label Branch SelectionMerge LoopMerge Return ReturnValue Variable FunctionParameter Line NoLine
CompositeExtract CompositeInsert CompositeConstruct VectorShuffle CopyObject Bitcast Phi Undef
ControlBarrier MemoryBarrier Unreachable Kill SampledImage Image
""".split())
_BRANCH = {"BranchConditional", "Switch"}
# storage a compiled shader keeps in registers: locals and parameters, an invocation's
# globals (Private), its built-in inputs (gl_GlobalInvocationID, ...)
REGISTERS = {"Function", "Private", "Input"}
_MEMORY_ACCESS = {"Load", "Store"}
_ATOMIC = re.compile(r"^Atomic\w+$")
_IMAGE = {"ImageFetch", "ImageRead", "ImageWrite", "ImageSampleImplicitLod", "ImageSampleExplicitLod",
          "ImageQuerySize", "ImageQuerySizeLod"}
_SUBGROUP = re.compile(r"^GroupNonUniform(\w+)$")
# GLSL.std.450 extended instructions: (alu, trans) a component of the result
_EXT = {
    **{n: (0, 1) for n in "Sqrt InverseSqrt Exp Exp2 Log Log2 Sin Cos Tan Asin Acos Atan Atan2 "
                          "Sinh Cosh Tanh".split()},
    "Pow": (1, 2),
    **{n: (1, 0) for n in "FMin FMax UMin UMax SMin SMax FAbs SAbs FSign SSign Floor Ceil Trunc "
                          "Round RoundEven Fract Fma FindILsb FindUMsb FindSMsb Radians Degrees "
                          "PackHalf2x16 UnpackHalf2x16 PackUnorm4x8 UnpackUnorm4x8 Ldexp".split()},
    **{n: (2, 0) for n in "FClamp UClamp SClamp FMix Step".split()},
    "SmoothStep": (5, 0),
    "Cross": (6, 0),
}
# GLSL.std.450 ops whose cost follows their operand's width n: (alu(n), trans)
_EXT_VECTOR = {
    "Normalize": lambda n: (3 * n - 1, 1),          # dot, inversesqrt, scale
    "Length": lambda n: (2 * n - 1, 1),             # dot, sqrt
    "Distance": lambda n: (3 * n - 1, 1),           # difference, dot, sqrt
    "Reflect": lambda n: (4 * n, 0),
}


# ---- the module -------------------------------------------------------------------------

_INSTR = re.compile(r"^\s*(?:(%[\w.]+)\s*=\s*)?Op(\w+)\s*(.*)$")


@dataclass
class Block:
    label: str
    ops: list = field(default_factory=list)       # (opcode, result id, operand words)
    succ: list = field(default_factory=list)
    loop: tuple | None = None                     # (merge, continue) for a loop header
    line: tuple | None = None                     # (file, line) of the loop statement


@dataclass
class Function:
    name: str                                     # the GLSL name (before the '(')
    blocks: dict = field(default_factory=dict)    # label -> Block, in order


class Module:
    """A parsed disassembly: types, constants, functions with their blocks."""

    def __init__(self, text: str):
        self.types: dict[str, tuple] = {}         # id -> ("scalar"|"vector"|..., ...)
        self.type_of: dict[str, str] = {}         # result id -> type id
        self.constants: set[str] = set()
        self.strings: dict[str, str] = {}
        self.names: dict[str, str] = {}
        self.functions: dict[str, Function] = {}
        self.by_id: dict[str, Function] = {}
        self._parse(text)

    def _parse(self, text: str) -> None:
        fn, block, line = None, None, None
        for raw in text.splitlines():
            m = _INSTR.match(raw)
            if not m:
                continue
            rid, op, rest = m.group(1), m.group(2), m.group(3)
            words = rest.split()
            if op == "String":
                self.strings[rid] = rest.strip().strip('"')
            elif op == "Name" and words:
                self.names[words[0]] = rest.split('"')[1] if '"' in rest else ""
            elif op.startswith("Type"):
                self._type(rid, op, words)
            elif op.startswith("Constant") or op.startswith("SpecConstant"):
                self.constants.add(rid)
                self.type_of[rid] = words[0] if words else ""
            elif op == "Function":
                name = self.names.get(rid, rid).split("(")[0]
                fn = Function(name)
                self.functions.setdefault(name, fn)
                self.by_id[rid] = fn
                self.type_of[rid] = words[0]
            elif op == "FunctionEnd":
                fn, block = None, None
            elif fn is None:
                if op == "Variable":
                    self.type_of[rid] = words[0]
            elif op == "Label":
                block = Block(rid)
                fn.blocks[rid] = block
            elif op == "Line":
                line = (self.strings.get(words[0], words[0]), int(words[1]))
            elif block is not None:
                if rid is not None and words:
                    self.type_of[rid] = words[0]
                if op == "LoopMerge":
                    block.loop, block.line = (words[0], words[1]), line
                elif op == "Branch":
                    block.succ = [words[0]]
                elif op == "BranchConditional":
                    block.succ = words[1:3]
                elif op == "Switch":
                    block.succ = words[3::2] + [words[1]]     # Selector Default (Literal Label)*
                block.ops.append((op, rid, words))
                if op == "FunctionParameter":
                    self.type_of[rid] = words[0]

    def _type(self, rid, op, words) -> None:
        if op in ("TypeFloat", "TypeInt", "TypeBool"):
            self.types[rid] = ("scalar", 1, 4)
        elif op == "TypeVector":
            n = int(words[1])
            self.types[rid] = ("vector", n, 4 * n)
        elif op == "TypePointer":
            self.types[rid] = ("pointer", words[0], words[1])
        elif op == "TypeStruct":
            self.types[rid] = ("struct", 1, sum(self.size(w) for w in words))
        elif op == "TypeArray":
            self.types[rid] = ("array", 1, self.size(words[0]) * self._literal(words[1]))
        else:
            self.types[rid] = (op, 1, 0)

    def _literal(self, cid: str) -> int:
        return 1        # an array's length is a constant id; a load of a whole array is rare

    def size(self, tid: str) -> int:
        return self.types.get(tid, ("", 1, 4))[2]

    def width(self, vid: str) -> int:
        """Components of a value's type (1 for scalars)."""
        t = self.types.get(self.type_of.get(vid, ""), ("scalar", 1, 4))
        return t[1] if t[0] == "vector" else 1

    def storage(self, pid: str) -> str:
        """Storage class of a pointer value."""
        t = self.types.get(self.type_of.get(pid, ""))
        return t[1] if t and t[0] == "pointer" else "Function"

    def pointee_size(self, pid: str) -> int:
        t = self.types.get(self.type_of.get(pid, ""))
        return self.size(t[2]) if t and t[0] == "pointer" else 4


# ---- counting ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Count:
    alu: float = 0.0
    trans: float = 0.0
    idiv: float = 0.0
    wred: float = 0.0

    def __add__(self, o: "Count") -> "Count":
        return Count(*(a + b for a, b in zip(self.row(), o.row())))

    def scaled(self, k: float) -> "Count":
        return Count(*(a * k for a in self.row()))

    def row(self) -> list[float]:
        return [self.alu, self.trans, self.idiv, self.wred]


ZERO = Count()


class Counter:
    """Counts of a module's functions and loops by the module doc's rule; `apart` names
    functions whose calls count nothing, `skip` holds (function, block) pairs that count
    nothing where a function is counted (the blocks of loops the model prices on their own)."""

    def __init__(self, module: Module, skip: frozenset = frozenset(), weight: dict | None = None):
        self.m = module
        self.skip = skip
        self.weight = weight or {}               # (function, block) -> times a call runs it

    def instruction(self, op: str, rid, words, apart: frozenset) -> Count:
        m = self.m
        if op in _FREE:
            return ZERO
        if op in _PER_COMPONENT:
            return Count(m.width(rid))
        if op in _PER_OPERAND:
            return Count(m.width(words[1]))
        if op in _MATRIX:                        # a multiply-add per row and column
            return Count(m.width(rid) * m.width(words[_MATRIX[op]]))
        if op == "FDiv":
            n = m.width(rid)
            return Count(n, n)
        if op in _INT_DIVISION:
            return Count(idiv=m.width(rid))
        if op in _BRANCH:
            return Count(1)
        if op in _MEMORY_ACCESS:
            ptr = words[1] if op == "Load" else words[0]
            if m.storage(ptr) in REGISTERS:
                return ZERO
            return Count(max(1, -(-m.pointee_size(ptr) // 16)))
        if op in ("AccessChain", "InBoundsAccessChain"):
            if m.storage(words[1]) in REGISTERS:
                return ZERO
            return Count(sum(1 for w in words[2:] if w not in m.constants))
        if _ATOMIC.match(op) or op in _IMAGE:
            return Count(1)
        sub = _SUBGROUP.match(op)
        if sub:
            reduce = "Reduce" in words or "InclusiveScan" in words or "ExclusiveScan" in words
            return Count(wred=1) if reduce else Count(1)
        if op == "ExtInst":
            name = words[2]
            n = m.width(rid)
            if name in _EXT_VECTOR:
                a, t = _EXT_VECTOR[name](m.width(words[3]))
                return Count(a, t)
            if name in _EXT:
                a, t = _EXT[name]
                return Count(a * n, t * n)
            raise ValueError(f"spirv: no counting rule for GLSL.std.450 {name}")
        if op == "FunctionCall":
            callee = m.by_id[words[1]]
            return ZERO if callee.name in apart else self.function(callee.name, apart)
        raise ValueError(f"spirv: no counting rule for Op{op}")

    def blocks(self, fn: Function, labels, apart: frozenset) -> Count:
        total = ZERO
        for lab in labels:
            block = ZERO
            for op, rid, words in fn.blocks[lab].ops:
                block += self.instruction(op, rid, words, apart)
            total += block.scaled(self.weight.get((fn.name, lab), 1))
        return total

    def function(self, name: str, apart: frozenset = frozenset()) -> Count:
        fn = self.m.functions[name]
        return self.blocks(fn, [b for b in fn.blocks if (name, b) not in self.skip], apart)

    def loop_blocks(self, fn: Function, header: str) -> list[str]:
        """The blocks of the loop headed by `header`: reachable from it without its merge."""
        merge = fn.blocks[header].loop[0]
        seen, todo = {header}, [header]
        while todo:
            for s in fn.blocks[todo.pop()].succ:
                if s != merge and s not in seen:
                    seen.add(s)
                    todo.append(s)
        return [b for b in fn.blocks if b in seen]

    def own_blocks(self, fn: Function, header: str) -> list[str]:
        """A loop's blocks less those of the loops nested in it."""
        own = set(self.loop_blocks(fn, header))
        for b in list(own):
            if b != header and fn.blocks[b].loop is not None:
                own -= set(self.loop_blocks(fn, b))
        return [b for b in fn.blocks if b in own]

    def loop_iteration(self, fn: Function, header: str, apart: frozenset) -> Count:
        """One iteration of a loop: its own blocks (a nested loop is priced as its own)."""
        return self.blocks(fn, self.own_blocks(fn, header), apart)

    def loops_at(self, file: str, line: int) -> list[tuple[Function, str]]:
        """The loops whose statement is at file:line, with their functions."""
        return [(fn, b.label) for fn in self.m.functions.values() for b in fn.blocks.values()
                if b.loop is not None and b.line == (file, line)]


# ---- compiling --------------------------------------------------------------------------

def tools() -> tuple[str, str]:
    exe = [shutil.which("glslangValidator"), shutil.which("spirv-dis")]
    if None in exe:
        raise UserError("the cost model counts instructions from SPIR-V: install glslang-tools "
                        "and spirv-tools (scripts/setup.sh does)")
    return exe[0], exe[1]


def with_file_lines(text: str, files: list[str]) -> str:
    """The loader's '#line N <file number>' as '#line N "<file>"', so that the SPIR-V's line
    information names the file a loop is written in."""
    head, _, body = text.partition("\n")
    body = re.sub(r"^#line (\d+) (\d+)$", lambda m: f'#line {m[1]} "{files[int(m[2])]}"', body,
                  flags=re.M)
    return f"{head}\n{LINE_EXTENSION}\n{body}"


def disassemble(text: str, stage: str) -> str:
    """glslang -> SPIR-V -> spirv-dis text of one stage."""
    glslang, dis = tools()
    with tempfile.TemporaryDirectory() as tmp:
        src, spv = Path(tmp) / f"p.{stage}", Path(tmp) / "p.spv"
        src.write_text(text)
        run = subprocess.run([glslang, *GLSLANG_ARGS, "-S", stage, str(src), "-o", str(spv)],
                             capture_output=True, text=True)
        if run.returncode != 0:
            log = (run.stdout + run.stderr).strip().splitlines()
            first = next((l for l in log if "ERROR" in l), log[-1] if log else "")
            raise UserError(f"glslang could not compile a program for the cost model: {first}")
        out = subprocess.run([dis, "--raw-id", str(spv)], capture_output=True)
        if out.returncode != 0:
            raise UserError(f"spirv-dis failed: {out.stderr.decode(errors='replace').strip()}")
        return out.stdout.decode(errors="replace")     # OpSource may quote any byte
