"""CasADi functions as compiled C, cached on disk, and evaluated on numpy buffers without copies.

gcc runs in background threads (`Compiling`): a run's maps compile in parallel with each other and with the rest
of its set-up, and a map that is never evaluated need not be waited for."""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import casadi as cs
import numpy as np

from harmony_cli.cache import CACHE_DIR

GCC_FLAGS = ("-O1", "-shared", "-fPIC")
_POOLS: dict[int, ThreadPoolExecutor] = {}  # per process id: a forked worker must not inherit its parent's threads


def _gcc_pool() -> ThreadPoolExecutor:
    """Threads that wait for gcc (a subprocess: the GIL is free meanwhile), this process's own."""
    pid = os.getpid()
    if pid not in _POOLS:
        _POOLS[pid] = ThreadPoolExecutor(max_workers=4, thread_name_prefix="harmony-gcc")
    return _POOLS[pid]


def library_path(name: str, source: str) -> Path:
    """Where `source` compiles to in the cache (named by its content)."""
    return CACHE_DIR / f"{name}_{hashlib.sha256(source.encode()).hexdigest()[:20]}.so"


def shared_library(name: str, source: str) -> Path:
    """C source built with gcc -O1 (1-6 s once) and cached on disk by content; raises if gcc is missing. Its
    results are CasADi VM's to the bit (no -ffast-math, no FMA contraction on x86-64's baseline ISA: the same IEEE
    operations in the same order)."""
    library = library_path(name, source)
    if not library.exists():
        CACHE_DIR.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=CACHE_DIR) as tmp:
            Path(tmp, "f.c").write_text(source)
            subprocess.run(
                ["gcc", *GCC_FLAGS, "f.c", "-o", "f.so"],
                cwd=tmp,
                check=True,
                capture_output=True,
                timeout=300,
            )
            os.replace(Path(tmp, "f.so"), library)  # atomic: concurrent processes never load half a file
    return library


class Compiling:
    """`f` as C, compiled in a background thread from now on (already cached: nothing to wait for); `function`
    waits for it and gives the compiled external, or f itself where gcc is missing (see code_path)."""

    def __init__(self, f: cs.Function):
        cg = cs.CodeGenerator(f.name(), {"with_header": False})
        cg.add(f)
        self.f, source = f, cg.dump()
        self._library: Future[Path] = _gcc_pool().submit(shared_library, f.name(), source)
        self._function: cs.Function | None = None

    @property
    def ready(self) -> bool:
        """Compiled (or failed): `function` will not wait."""
        return self._library.done()

    @property
    def function(self) -> cs.Function:
        if self._function is None:
            try:
                self._function = cs.external(self.f.name(), str(self._library.result()))
            except (OSError, subprocess.SubprocessError, RuntimeError):
                self._function = self.f
        return self._function


def compiled(f: cs.Function) -> cs.Function:
    """f as C: ~10x faster than CasADi's VM; f itself where gcc is missing (see code_path)."""
    return Compiling(f).function


def code_path(f: cs.Function) -> str:
    """How `compiled` evaluates f: "compiled C" or "CasADi VM" (no gcc: ~10x slower, recorded in meta.json)."""
    return "compiled C" if f.class_name() == "External" else "CasADi VM"


class Buffered:
    """Zero-copy evaluation of a CasADi Function on preallocated numpy arrays of each input's/output's nonzeros
    (numpy <-> DM conversion through Python costs ~1 ms for a 108 x 108 matrix; this path costs microseconds)."""

    def __init__(self, f: cs.Function):
        self.args = {n: np.zeros(f.nnz_in(i)) for i, n in enumerate(f.name_in())}
        self.res = {n: np.zeros(f.nnz_out(i)) for i, n in enumerate(f.name_out())}
        self._buffer, self._eval = f.buffer()
        for i, n in enumerate(f.name_in()):
            self._buffer.set_arg(i, self.args[n].data)
        for i, n in enumerate(f.name_out()):
            self._buffer.set_res(i, self.res[n].data)

    def __call__(self, **inputs) -> dict[str, np.ndarray]:
        for name, value in inputs.items():
            self.args[name][:] = np.ravel(value, order="F")
        self._eval()
        return self.res

    def stats(self) -> dict:
        return self._buffer.stats()
