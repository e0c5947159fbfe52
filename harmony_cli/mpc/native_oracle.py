"""The cost's f, gradient and Hessian as one C function that CasADi calls directly (no Python in the solve).

It is KnotDerivatives' assembly (whose numpy path is the reference the tests compare it with) written in C
around CasADi's generated code for the per-knot maps: IPOPT's 12 derivative calls per solve cost ~3 ms through
Python callbacks and a few hundred microseconds here.
"""

from __future__ import annotations

import subprocess

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import shared_library
from harmony_cli.mpc.knot_derivatives import KnotDerivatives

ASSEMBLY = r"""
#pragma GCC optimize ("O3")  /* the loops below vectorise; the generated code above stays at -O1 */
#define ND {nd}
#define NPOS {npos}
#define K {K}
#define M {m}
#define NV {n}
#define NPAIRS {npairs}
#define NNZ {nnz}
#define NLIN {nlin}
#define NBLK (NPAIRS * ND * ND)
#define SZ_ARG {sz_arg}
#define SZ_RES {sz_res}

static const casadi_real B[] = {{{B}}};  /* K x NPOS, row-major */
static const casadi_real W[] = {{{W}}};  /* NPAIRS x K, row-major */
static const casadi_int NL_INDEX[] = {{{nl_index}}};  /* Hessian nonzero -> knot block entry (NBLK: none) */
static const casadi_real LIN_VALS[] = {{{lin_vals}}};
static const casadi_int L_PTR[] = {{{L_ptr}}}, L_IND[] = {{{L_ind}}};  /* linear residual L x + c, CSR */
static const casadi_real L_VAL[] = {{{L_val}}}, C0[] = {{{c}}};
static const casadi_int S_PTR[] = {{{S_ptr}}}, S_IND[] = {{{S_ind}}};  /* parameters in it: + S p, CSR */
static const casadi_real S_VAL[] = {{{S_val}}};
static const casadi_int SP_X[] = {{NV, 1, 1}}, SP_P[] = {{{n_p}, 1, 1}}, SP_F[] = {{1, 1, 1}};
static const casadi_int SP_H[] = {{NV, NV, {h_colind}, {h_rows}}};

CASADI_SYMBOL_EXPORT casadi_int harmony_oracle_n_in(void) {{ return 2; }}
CASADI_SYMBOL_EXPORT casadi_int harmony_oracle_n_out(void) {{ return 3; }}
CASADI_SYMBOL_EXPORT const char* harmony_oracle_name_in(casadi_int i) {{ return i == 0 ? "x" : "p"; }}
CASADI_SYMBOL_EXPORT const char* harmony_oracle_name_out(casadi_int i) {{ return i == 0 ? "f" : i == 1 ? "g" : "h"; }}
CASADI_SYMBOL_EXPORT const casadi_int* harmony_oracle_sparsity_in(casadi_int i) {{ return i == 0 ? SP_X : SP_P; }}
CASADI_SYMBOL_EXPORT const casadi_int* harmony_oracle_sparsity_out(casadi_int i) {{
  return i == 0 ? SP_F : i == 1 ? SP_X : SP_H;
}}
CASADI_SYMBOL_EXPORT int harmony_oracle_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw,
                                             casadi_int* sz_w) {{
  *sz_arg = 2; *sz_res = 3; *sz_iw = {sz_iw};
  *sz_w = ND * K + M * K + ND * M * K + K * ND * ND + NBLK + NLIN + {sz_w};
  return 0;
}}

/* f, gradient and Hessian values on the pattern SP_H; only the outputs asked for (res[i] != 0) */
CASADI_SYMBOL_EXPORT int harmony_oracle(const casadi_real** arg, casadi_real** res, casadi_int* iw,
                                        casadi_real* w, int mem) {{
  const casadi_real *x = arg[0], *p = arg[1];
  casadi_real *Q = w, *R = Q + ND * K, *JT = R + M * K, *HK = JT + ND * M * K, *BLK = HK + K * ND * ND;
  casadi_real *RL = BLK + NBLK, *wk = RL + NLIN;
  const casadi_real* a[SZ_ARG] = {{0}};
  casadi_real* r[SZ_RES] = {{0}};
  casadi_int i, j, k, z;
  for (k = 0; k < K; ++k)  /* q_k = X_pos b_k */
    for (i = 0; i < ND; ++i) {{
      casadi_real s = 0;
      for (j = 0; j < NPOS; ++j) s += x[j * ND + i] * B[k * NPOS + j];
      Q[k * ND + i] = s;
    }}
  a[0] = Q; a[1] = p;
  if (res[0] || res[1]) {{
    casadi_real f = 0;
    r[0] = R; r[1] = res[1] ? JT : 0;
    if (res[1] ? {gradient}(a, r, iw, wk, 0) : {value}(a, r, iw, wk, 0)) return 1;
    for (i = 0; i < M * K; ++i) f += R[i] * R[i];
    for (i = 0; i < NLIN; ++i) {{
      casadi_real s = C0[i];
      for (z = L_PTR[i]; z < L_PTR[i + 1]; ++z) s += L_VAL[z] * x[L_IND[z]];
      for (z = S_PTR[i]; z < S_PTR[i + 1]; ++z) s += S_VAL[z] * p[S_IND[z]];
      RL[i] = s; f += s * s;
    }}
    if (res[0]) res[0][0] = f;
    if (res[1]) {{
      casadi_real* g = res[1];
      for (i = 0; i < NV; ++i) g[i] = 0;
      for (i = 0; i < NLIN; ++i)
        for (z = L_PTR[i]; z < L_PTR[i + 1]; ++z) g[L_IND[z]] += 2 * L_VAL[z] * RL[i];
      for (k = 0; k < K; ++k)
        for (i = 0; i < ND; ++i) {{  /* 2 J_k^T r_k, spread over the control points by b_k */
          casadi_real s = 0;
          for (j = 0; j < M; ++j) s += JT[(k * M + j) * ND + i] * R[k * M + j];
          for (z = 0; z < NPOS; ++z) g[z * ND + i] += 2 * B[k * NPOS + z] * s;
        }}
    }}
  }}
  if (res[2]) {{
{knot_hessians}
    for (z = 0; z < NPAIRS; ++z) {{  /* block (a, b) = sum_k B[k, a] B[k, b] H_k, 8 sums at a time in registers */
      const casadi_real* w = W + z * K;
      casadi_real* out = BLK + z * ND * ND;
      for (i = 0; i + 8 <= ND * ND; i += 8) {{
        casadi_real s[8] = {{0}};
        for (k = 0; k < K; ++k)
          for (j = 0; j < 8; ++j) s[j] += w[k] * HK[k * ND * ND + i + j];
        for (j = 0; j < 8; ++j) out[i + j] = s[j];
      }}
      for (; i < ND * ND; ++i) {{
        casadi_real s = 0;
        for (k = 0; k < K; ++k) s += w[k] * HK[k * ND * ND + i];
        out[i] = s;
      }}
    }}
    for (z = 0; z < NNZ; ++z) res[2][z] = LIN_VALS[z] + (NL_INDEX[z] < NBLK ? BLK[NL_INDEX[z]] : 0);
  }}
  return 0;
}}

/* Reverse mode, which nlpsol needs to set up: adj_x = adj_f grad + H adj_g. Third derivatives (a seed on the
   Hessian) are not provided: the call fails. Derivatives in p are not provided: NaN, never a silent zero. */
CASADI_SYMBOL_EXPORT casadi_int adj1_harmony_oracle_n_in(void) {{ return 8; }}
CASADI_SYMBOL_EXPORT casadi_int adj1_harmony_oracle_n_out(void) {{ return 2; }}
CASADI_SYMBOL_EXPORT const casadi_int* adj1_harmony_oracle_sparsity_in(casadi_int i) {{
  return i < 2 ? harmony_oracle_sparsity_in(i) : harmony_oracle_sparsity_out((i - 2) % 3);
}}
CASADI_SYMBOL_EXPORT const casadi_int* adj1_harmony_oracle_sparsity_out(casadi_int i) {{
  return harmony_oracle_sparsity_in(i);
}}
CASADI_SYMBOL_EXPORT int adj1_harmony_oracle_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw,
                                                  casadi_int* sz_w) {{
  harmony_oracle_work(sz_arg, sz_res, sz_iw, sz_w);
  *sz_arg = 8; *sz_res = 2; *sz_w += NV + NNZ;
  return 0;
}}
CASADI_SYMBOL_EXPORT int adj1_harmony_oracle(const casadi_real** arg, casadi_real** res, casadi_int* iw,
                                             casadi_real* w, int mem) {{
  const casadi_real* a[2] = {{arg[0], arg[1]}};
  const casadi_int *colind = SP_H + 2, *row = SP_H + 3 + NV;
  casadi_real *G = w, *H = G + NV, *r[3] = {{0, G, arg[6] ? H : 0}};
  casadi_int i, z;
  if (arg[7])
    for (z = 0; z < NNZ; ++z)
      if (arg[7][z] != 0) return 1;
  if (harmony_oracle(a, r, iw, H + NNZ, 0)) return 1;
  if (res[0]) {{
    for (i = 0; i < NV; ++i) res[0][i] = arg[5] ? arg[5][0] * G[i] : 0;
    if (arg[6])
      for (i = 0; i < NV; ++i)
        for (z = colind[i]; z < colind[i + 1]; ++z) res[0][row[z]] += H[z] * arg[6][i];
  }}
  if (res[1])
    for (i = 0; i < {n_p}; ++i) res[1][i] = NAN;
  return 0;
}}
"""

EXACT_HESSIANS = "    r[0] = HK; if ({hessian}(a, r, iw, wk, 0)) return 1;"
GAUSS_NEWTON_HESSIANS = """    r[0] = R; r[1] = JT; if ({gradient}(a, r, iw, wk, 0)) return 1;
    for (k = 0; k < K; ++k)  /* H_k = 2 J_k^T J_k */
      for (i = 0; i < ND; ++i)
        for (j = 0; j < ND; ++j) {{
          casadi_real s = 0;
          for (z = 0; z < M; ++z) s += JT[(k * M + z) * ND + i] * JT[(k * M + z) * ND + j];
          HK[(k * ND + i) * ND + j] = 2 * s;
        }}"""


def _c_array(values) -> str:
    values = np.asarray(values).ravel()
    if values.size == 0:
        return "0"
    return ", ".join(repr(float(v)) for v in values) if values.dtype.kind == "f" else ", ".join(map(str, values))


def native_oracle(model: KnotDerivatives, n_p: int) -> cs.Function | None:
    """(x, p) -> (f, gradient, Hessian on model's pattern) as a compiled CasADi external; None without gcc. Made
    once per model (shared by the solvers of one problem: mpc/structures.py)."""
    if n_p not in model.native:
        model.native[n_p] = _native_oracle(model, n_p)
    return model.native[n_p]


def _native_oracle(model: KnotDerivatives, n_p: int) -> cs.Function | None:
    maps = {kind: f for kind, f in model.knot_functions.items() if kind != "normal"}  # its own assembly in C
    cg = cs.CodeGenerator("harmony_oracle", {"with_header": False})
    for f in maps.values():
        cg.add(f)
    names = {kind: f.name() for kind, f in maps.items()}
    n, (K, npos) = model.n_vars, model.B.shape
    L, S = model.L.tocsr(), model.S.tocsr()
    colind = np.r_[0, np.cumsum(np.bincount(model.cols, minlength=n))]
    hessians = (EXACT_HESSIANS if model.exact else GAUSS_NEWTON_HESSIANS).format(**names)
    source = cg.dump() + ASSEMBLY.format(
        nd=model.n_dof,
        npos=npos,
        K=K,
        m=model.m,
        n=n,
        n_p=n_p,
        npairs=model.W.shape[0],
        nnz=model.rows.size,
        nlin=L.shape[0],
        sz_arg=max(f.sz_arg() for f in maps.values()),
        sz_res=max(f.sz_res() for f in maps.values()),
        sz_iw=max(f.sz_iw() for f in maps.values()),
        sz_w=max(f.sz_w() for f in maps.values()),
        B=_c_array(model.B),
        W=_c_array(model.W),
        nl_index=_c_array(model.nl_index),
        lin_vals=_c_array(model.lin_vals),
        L_ptr=_c_array(L.indptr),
        L_ind=_c_array(L.indices),
        L_val=_c_array(L.data),
        c=_c_array(model.c),
        S_ptr=_c_array(S.indptr),
        S_ind=_c_array(S.indices),
        S_val=_c_array(S.data),
        h_colind=_c_array(colind),
        h_rows=_c_array(model.rows),
        knot_hessians=hessians,
        **names,
    )
    try:
        return cs.external("harmony_oracle", str(shared_library("harmony_oracle", source)))
    except (OSError, subprocess.SubprocessError, RuntimeError):
        return None
