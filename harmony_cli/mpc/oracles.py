"""The cost and clearance derivatives of the knot structure as CasADi callbacks into Python: the fallback of the
native C oracle where gcc is missing (~3 ms per IPOPT solve), and the clearance rows' derivatives (they exist
only with obstacles; the cost keeps its native oracle)."""

from __future__ import annotations

import casadi as cs
import numpy as np

from harmony_cli.mpc.knot_constraints import KnotConstraints
from harmony_cli.mpc.knot_derivatives import KnotDerivatives


class _Buffered(cs.Callback):
    """A callback on dense inputs of `sizes` with outputs of sparsities `out`, evaluated on CasADi's buffers."""

    sizes: tuple[int, ...]
    out: list

    def get_n_in(self):
        return len(self.sizes)

    def get_n_out(self):
        return len(self.out)

    def get_sparsity_in(self, i):
        return cs.Sparsity.dense(self.sizes[i])

    def get_sparsity_out(self, i):
        return self.out[i]

    def has_eval_buffer(self):
        return True

    def inputs(self, arg) -> list[np.ndarray]:
        """The inputs as arrays (CasADi passes None for a zero input)."""
        return [np.zeros(n) if a is None else np.frombuffer(a, dtype=float) for n, a in zip(self.sizes, arg)]

    @staticmethod
    def write(res, values) -> int:
        """Each wanted output (CasADi passes None for the others) from `values`."""
        for buffer, value in zip(res, values):
            if buffer is not None:
                np.frombuffer(buffer, dtype=float)[:] = value
        return 0


class Oracle(_Buffered):
    """(x, p) -> f, (f, gradient) or Hessian (full symmetric pattern) from a KnotDerivatives."""

    def __init__(self, model: KnotDerivatives, kind: str, n_p: int):
        cs.Callback.__init__(self)
        self.grad: Oracle | None = None  # the gradient callback, whose reverse mode f has (set by the user)
        self.model, self.kind, self.sizes, n = model, kind, (model.n_vars, n_p), model.n_vars
        self.out = {
            "f": [cs.Sparsity.dense(1)],
            "grad": [cs.Sparsity.dense(1), cs.Sparsity.dense(n)],
            "hess": [cs.Sparsity.triplet(n, n, model.rows.tolist(), model.cols.tolist())],
        }[kind]
        self.construct(f"structured_{kind}", {})

    def has_reverse(self, n_adj):
        return self.kind == "f" and n_adj == 1

    def get_reverse(self, n_adj, name, inames, onames, opts):  # df = gradient dx (nlpsol builds nlp_grad with it)
        x, p, f, adj = (cs.MX.sym(v, s) for v, s in zip("xpfa", (*self.sizes, 1, 1)))
        if self.grad is None:
            raise RuntimeError("Oracle('f') needs its gradient oracle in .grad for reverse mode")
        return cs.Function(name, [x, p, f, adj], [adj * self.grad(x, p)[1], cs.MX(self.sizes[1], 1)], inames, onames)

    def eval_buffer(self, arg, res):
        x, p = self.inputs(arg)
        values = {
            "f": lambda: [self.model.value(x, p)],
            "grad": lambda: self.model.gradient(x, p),
            "hess": lambda: [self.model.hessian(x, p)],
        }[self.kind]()
        return self.write(res, values)


class ConstraintOracle(_Buffered):
    """(x, p) -> (h, dh/dx) ("jac"), or (x, p, lam) -> Hessian of lam . h on the cost Hessian's pattern ("hess"),
    from KnotConstraints (Python: these rows exist only with obstacles; the cost keeps its native oracle)."""

    def __init__(self, constraints: KnotConstraints, model: KnotDerivatives, kind: str, n_p: int):
        cs.Callback.__init__(self)
        self.constraints, self.model, self.kind, n = constraints, model, kind, model.n_vars
        self.sizes = (n, n_p) if kind == "jac" else (n, n_p, constraints.n_rows)
        rows, cols = np.nonzero(constraints.pattern)
        self.jac_order = np.lexsort((rows, cols))  # CCS order of the Jacobian's nonzeros
        self.jac_index = rows[self.jac_order], cols[self.jac_order]
        self.out = {
            "jac": [
                cs.Sparsity.dense(constraints.n_rows),
                cs.Sparsity.triplet(constraints.n_rows, n, *(i.tolist() for i in self.jac_index)),
            ],
            "hess": [cs.Sparsity.triplet(n, n, model.rows.tolist(), model.cols.tolist())],
        }[kind]
        self.construct(f"constraint_{kind}", {})

    def has_reverse(self, n_adj):
        return self.kind == "jac" and n_adj == 1

    def get_reverse(self, n_adj, name, inames, onames, opts):  # dh^T adj (nlpsol's Lagrangian gradient)
        x, p = cs.MX.sym("x", self.sizes[0]), cs.MX.sym("p", self.sizes[1])
        h, jac = cs.MX.sym("h", self.out[0]), cs.MX.sym("jac", self.out[1])
        adj_h, adj_jac = cs.MX.sym("adj_h", self.out[0]), cs.MX.sym("adj_jac", self.out[1])
        return cs.Function(
            name,
            [x, p, h, jac, adj_h, adj_jac],
            [cs.densify(cs.mtimes(self(x, p)[1].T, adj_h)), cs.MX(self.sizes[1], 1)],
            inames,
            onames,
        )

    def eval_buffer(self, arg, res):
        x, p, *lam = self.inputs(arg)
        if self.kind == "jac":
            h, _, C = self.constraints.evaluate(x, p)
            return self.write(res, [h, C[self.jac_index]])
        return self.write(res, [self.model.assemble(self.constraints.curvature(x, p, lam[0]))])
