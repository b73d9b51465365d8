// Leading eigenvectors of symmetric matrices (the Gram matrices of HOSVD/HOOI), one entry point
// per instruction-set level.
#include <algorithm>
#include <cmath>

#include "tensor/decompose_simd.hpp"
#include "tensor/decompose_variants.hpp"

namespace strata::tensor::detail {
namespace {

// ---- Symmetric eigen-decomposition ----------------------------------------------------------
// Householder tridiagonalisation on the full (both triangles) matrix, so every update is an axpy
// over contiguous columns, then the implicit QL iteration with Wilkinson shifts of EISPACK tql2
// (as in JAMA), whose Givens rotations update two contiguous columns of the eigenvector matrix.
// For the 32 x 32 Gram matrices of bricks this is several times faster than Eigen's
// SelfAdjointEigenSolver, whose tridiagonalisation and rotations run on 2-wide SSE2 vectors.

template <int VW>
[[gnu::always_inline]] inline double dot(const double* __restrict x, const double* __restrict y, std::int64_t n) {
  using V = typename DVecOf<VW>::type;
  V acc0{}, acc1{};
  std::int64_t i = 0;
  for (; i + 2 * VW <= n; i += 2 * VW) {
    acc0 += load<VW>(x + i) * load<VW>(y + i);
    acc1 += load<VW>(x + i + VW) * load<VW>(y + i + VW);
  }
  if (i + VW <= n) {
    acc0 += load<VW>(x + i) * load<VW>(y + i);
    i += VW;
  }
  double s = hsum<VW>(acc0 + acc1);
  for (; i < n; ++i) s += x[i] * y[i];
  return s;
}

// y += a x
template <int VW>
[[gnu::always_inline]] inline void axpy(double a, const double* __restrict x, double* __restrict y, std::int64_t n) {
  std::int64_t i = 0;
  for (; i + VW <= n; i += VW) store<VW>(y + i, load<VW>(y + i) + load<VW>(x + i) * a);
  for (; i < n; ++i) y[i] += a * x[i];
}

// y -= a x + b z
template <int VW>
[[gnu::always_inline]] inline void sub_axpy2(double a, const double* __restrict x, double b,
                                             const double* __restrict z, double* __restrict y, std::int64_t n) {
  std::int64_t i = 0;
  for (; i + VW <= n; i += VW) store<VW>(y + i, load<VW>(y + i) - load<VW>(x + i) * a - load<VW>(z + i) * b);
  for (; i < n; ++i) y[i] -= a * x[i] + b * z[i];
}

// (x, y) <- (c x - s y, s x + c y): the Givens rotation of tql2 on two eigenvector columns.
template <int VW>
[[gnu::always_inline]] inline void rotate(double c, double s, double* __restrict x, double* __restrict y,
                                          std::int64_t n) {
  std::int64_t i = 0;
  for (; i + VW <= n; i += VW) {
    const auto xv = load<VW>(x + i), yv = load<VW>(y + i);
    store<VW>(x + i, xv * c - yv * s);
    store<VW>(y + i, xv * s + yv * c);
  }
  for (; i < n; ++i) {
    const double xv = x[i], yv = y[i];
    x[i] = c * xv - s * yv;
    y[i] = s * xv + c * yv;
  }
}

// sqrt(a² + b²) without the cost of std::hypot in the common case.
inline double hypot_fast(double a, double b) {
  const double r = std::sqrt(a * a + b * b);
  if (r >= 1e-150 && r <= 1e150) return r;
  return std::hypot(a, b);  // over- or underflow of the squares (or NaN)
}

// 1. Householder tridiagonalisation: H_k = I - tau_k u u^T (u(0) = 1) zeroes A(k+2:n, k); d and e
// receive the diagonal and sub-diagonal (e[k] couples k and k + 1). Column k of `a` keeps u in
// rows k+1.. and is zeroed above, so that every loop can run over whole vectors from the
// vector-aligned row below k + 1 (the extra rows contribute zeros).
template <int VW>
[[gnu::always_inline]] inline void tridiagonalize(double* a, std::int64_t n, double* d, double* e, double* tau,
                                                  double* p) {
  auto A = [&](std::int64_t i, std::int64_t j) -> double& { return a[i + j * n]; };
  for (std::int64_t k = 0; k + 2 < n; ++k) {
    const std::int64_t r0 = (k + 1) / VW * VW, len = n - r0;  // aligned row range [r0, n)
    double* x = &A(0, k);
    d[k] = x[k];
    for (std::int64_t i = r0; i <= k; ++i) x[i] = 0;
    const double alpha = x[k + 1];
    x[k + 1] = 0;
    const double xnorm2 = dot<VW>(x + r0, x + r0, len);
    if (xnorm2 == 0) {
      tau[k] = 0;
      e[k] = alpha;
      continue;
    }
    const double beta = -std::copysign(std::sqrt(alpha * alpha + xnorm2), alpha);
    const double t = (beta - alpha) / beta;
    tau[k] = t;
    e[k] = beta;
    const double scale = 1.0 / (alpha - beta);
    for (std::int64_t i = k + 2; i < n; ++i) x[i] *= scale;
    x[k + 1] = 1.0;
    // Trailing block S = A(k+1:n, k+1:n) <- H S H = S - u w^T - w u^T, with p = tau S u and
    // w = p - (tau/2)(p·u) u. p accumulates columns of S (an axpy per column, no reduction);
    // its rows above k + 1 pick up stale entries of A and are cleared.
    // Each vector of p accumulates in a register over the columns (no store-load chain).
    {
      using V = typename DVecOf<VW>::type;
      std::int64_t row = r0;
      for (; row + VW <= n; row += VW) {
        V acc{};
        for (std::int64_t j = k + 1; j < n; ++j) acc += load<VW>(&A(row, j)) * (t * x[j]);
        store<VW>(p + row, acc);
      }
      for (; row < n; ++row) {
        double acc = 0;
        for (std::int64_t j = k + 1; j < n; ++j) acc += A(row, j) * (t * x[j]);
        p[row] = acc;
      }
    }
    for (std::int64_t i = r0; i <= k; ++i) p[i] = 0;
    const double half = 0.5 * t * dot<VW>(p + r0, x + r0, len);
    axpy<VW>(-half, x + r0, p + r0, len);  // p is now w
    for (std::int64_t j = k + 1; j < n; ++j) sub_axpy2<VW>(p[j], x + r0, x[j], p + r0, &A(r0, j), len);
  }
  if (n >= 2) {
    d[n - 2] = A(n - 2, n - 2);
    e[n - 2] = A(n - 1, n - 2);
  }
  d[n - 1] = A(n - 1, n - 1);
  e[n - 1] = 0;
}

// 2. Q = H_0 H_1 ... H_{n-3}, accumulated backwards: H_k only touches rows and columns > k, and
// rows <= k of those columns are still zero, as are rows <= k of u.
template <int VW>
[[gnu::always_inline]] inline void accumulate_householder(const double* a, std::int64_t n, const double* tau,
                                                          double* v) {
  std::fill(v, v + n * n, 0.0);
  for (std::int64_t i = 0; i < n; ++i) v[i + i * n] = 1.0;
  for (std::int64_t k = n - 3; k >= 0; --k) {
    if (tau[k] == 0) continue;
    const std::int64_t r0 = (k + 1) / VW * VW, len = n - r0;
    const double* u = a + k * n + r0;
    for (std::int64_t j = k + 1; j < n; ++j) {
      double* col = v + j * n + r0;
      axpy<VW>(-tau[k] * dot<VW>(u, col, len), u, col, len);
    }
  }
}

// 3. tql2: implicit QL with Wilkinson shifts on the tridiagonal (d, e), rotations accumulated
// into the columns of v. Then increasing eigenvalues (selection sort, swapping columns).
template <int VW>
[[gnu::always_inline]] inline bool tql2(double* d, double* e, std::int64_t n, double* v) {
  double f = 0, tst1 = 0;
  constexpr double eps = 0x1p-52;
  for (std::int64_t l = 0; l < n; ++l) {
    tst1 = std::max(tst1, std::abs(d[l]) + std::abs(e[l]));
    std::int64_t m = l;
    while (m < n && !(std::abs(e[m]) <= eps * tst1)) ++m;
    if (m == n) m = n - 1;  // e[n - 1] is 0: only NaN gets here
    if (m > l) {
      int iterations = 0;
      do {
        if (++iterations > 60) return false;
        double g = d[l];
        double p = (d[l + 1] - g) / (2.0 * e[l]);
        double r = hypot_fast(p, 1.0);
        if (p < 0) r = -r;
        d[l] = e[l] / (p + r);
        d[l + 1] = e[l] * (p + r);
        const double dl1 = d[l + 1];
        double h = g - d[l];
        for (std::int64_t i = l + 2; i < n; ++i) d[i] -= h;
        f += h;
        p = d[m];
        double c = 1.0, c2 = 1.0, c3 = 1.0, s = 0.0, s2 = 0.0;
        const double el1 = e[l + 1];
        for (std::int64_t i = m - 1; i >= l; --i) {
          c3 = c2;
          c2 = c;
          s2 = s;
          g = c * e[i];
          h = c * p;
          r = hypot_fast(p, e[i]);
          e[i + 1] = s * r;
          s = e[i] / r;
          c = p / r;
          p = c * d[i] - s * g;
          d[i + 1] = h + s * (c * g + s * d[i]);
          rotate<VW>(c, s, v + i * n, v + (i + 1) * n, n);
        }
        p = -s * s2 * c3 * el1 * e[l] / dl1;
        e[l] = s * p;
        d[l] = c * p;
      } while (std::abs(e[l]) > eps * tst1);
    }
    d[l] += f;
    e[l] = 0;
  }
  for (std::int64_t i = 0; i + 1 < n; ++i) {
    std::int64_t k = i;
    for (std::int64_t j = i + 1; j < n; ++j)
      if (d[j] < d[k]) k = j;
    if (k != i) {
      std::swap(d[i], d[k]);
      std::swap_ranges(v + i * n, v + (i + 1) * n, v + k * n);
    }
  }
  for (std::int64_t i = 0; i < n; ++i)
    if (!std::isfinite(d[i])) return false;
  return true;
}

// ---- Leading eigenvectors -------------------------------------------------------------------
// The decompositions need only the r eigenvectors of the largest eigenvalues, and the QL
// iteration above is bound by the latency of its chain of square roots and divisions (about 40
// cycles per rotation, n^2 rotations). Instead, after the same tridiagonalisation T = Q^T A Q:
//  - bisection with Sturm counts finds the r largest eigenvalues of T, vectorised across them:
//    the count uses the three-term continuant p_k = (d_k - x) p_{k-1} - e_{k-1}^2 p_{k-2}
//    (Givens/Wilkinson), whose only dependency is one FMA per step, on T scaled to norm ~1
//    and rescaled every few steps so that p_k neither overflows nor underflows;
//  - each eigenvector of T comes from one twisted factorisation of T - lambda I (the forward
//    LDL^T and backward UDU^T recurrences meet at the index of least |gamma|), as in the
//    MRRR algorithm of Dhillon and Parlett, again vectorised across eigenvalues;
//  - Q maps them back, and modified Gram-Schmidt makes them orthonormal to working precision.
// Eigenvalues below kNegligible ||A|| carry no information at double precision (they are at the
// level of the rounding errors of the Gram matrix of float data): any orthonormal completion
// serves as their vectors. If vectors of larger eigenvalues collapse (nearly equal
// eigenvalues), fail the final residual check or anything is not finite, the QL iteration above
// takes over.

constexpr double kSmall = 0x1p-400, kBig = 0x1p400;
constexpr double kNegligible = 1e-13;  // eigenvalue / ||A||

// Lanes j of group g hold eigenvalue index k = n - 1 - (first + g VW + j), clamped to >= n - r.
template <int VW, int G>
[[gnu::always_inline]] inline void bisect(const double* ds, const double* e2s, std::int64_t n, std::int64_t first,
                                          std::int64_t r, double glo, double ghi, double* lam) {
  using V = typename DVecOf<VW>::type;
  using U = typename UVecOf<VW>::type;
  V lo[G], hi[G];
  U target[G];
  for (int g = 0; g < G; ++g) {
    lo[g] = V{} + glo;
    hi[g] = V{} + ghi;
    std::uint64_t t[VW];
    for (int j = 0; j < VW; ++j) t[j] = std::uint64_t(n - 1 - std::min(first + g * VW + j, r - 1));
    __builtin_memcpy(&target[g], t, sizeof(t));
  }
  constexpr double eps = 0x1p-52;
  for (int iteration = 0; iteration < 80; ++iteration) {
    V mid[G], p[G], pp[G];
    U count[G];
    for (int g = 0; g < G; ++g) {
      mid[g] = (lo[g] + hi[g]) * 0.5;
      pp[g] = V{} + 1.0;
      p[g] = ds[0] - mid[g];
      count[g] = (U)p[g] >> 63;  // sign change from p_{-1} = 1
    }
    for (std::int64_t k = 1; k < n; ++k) {
      const double dk = ds[k], ek = e2s[k - 1];
      for (int g = 0; g < G; ++g) {
        const V next = (dk - mid[g]) * p[g] - ek * pp[g];
        count[g] += ((U)next ^ (U)p[g]) >> 63;  // sign bits differ
        pp[g] = p[g];
        p[g] = next;
      }
      // |p_k| grows by at most 3 per step (|d - x| <= 2, e^2 <= 1), and a pair (p_k, p_{k-1})
      // shrinks by at most about e_min^2 per step: rescaling every 8 steps keeps it in range.
      if ((k & 7) == 0) {
        for (int g = 0; g < G; ++g) {
          const U magnitude = ~U{} >> 1;  // all bits but the sign
          const V ap = (V)((U)p[g] & magnitude), app = (V)((U)pp[g] & magnitude);
          const V big = ap > app ? ap : app;
          const V scale = big < kSmall ? V{} + kBig : (big > kBig ? V{} + kSmall : V{} + 1.0);
          p[g] *= scale;
          pp[g] *= scale;
        }
      }
    }
    // Converged: relative 2 eps, or 1e-13 absolute (T is scaled to norm ~1): the twisted vectors
    // need lambda to within a small fraction of its gap to the neighbours, and eigenvalues below
    // kNegligible are not resolved anyway.
    bool converged = true;
    for (int g = 0; g < G; ++g) {
      // count = number of eigenvalues below mid; lambda_target < mid iff count > target.
      const auto below = count[g] > target[g];
      hi[g] = below ? mid[g] : hi[g];
      lo[g] = below ? lo[g] : mid[g];
      for (int j = 0; j < VW; ++j)
        converged &= hi[g][j] - lo[g][j] <= 2 * eps * std::max(std::abs(lo[g][j]), std::abs(hi[g][j])) + 1e-13;
    }
    if (converged) break;
  }
  for (int g = 0; g < G; ++g)
    for (int j = 0; j < VW; ++j)
      if (first + g * VW + j < r) lam[first + g * VW + j] = 0.5 * (lo[g][j] + hi[g][j]);
}

template <int VW>
[[gnu::always_inline]] inline typename DVecOf<VW>::type vsqrt(typename DVecOf<VW>::type x) {
  for (int j = 0; j < VW; ++j) x[j] = std::sqrt(x[j]);
  return x;
}

// A pivot of the twisted factorisation, kept away from zero (T is scaled to norm ~1).
template <int VW>
[[gnu::always_inline]] inline typename DVecOf<VW>::type guard(typename DVecOf<VW>::type x) {
  constexpr double pivmin = 0x1p-960;
  const auto ax = x < 0.0 ? -x : x;
  return ax < pivmin ? x - x + pivmin : x;
}

// Eigenvectors of the scaled T for lam[first ..] (VW G at a time) by twisted factorisation,
// written as columns of z (n x r, column-major). `scratch` holds 4 n VW G doubles.
// Then maps them back to A's basis, z <- H_0 ... H_{n-3} z, with the reflectors kept in the
// columns of `a` (row-major across the lanes: every update is a vector FMA, no reductions).
template <int VW, int G>
[[gnu::always_inline]] inline bool twisted_vectors(const double* ds, const double* esc, std::int64_t n,
                                                   std::int64_t first, std::int64_t r, const double* lam,
                                                   const double* a, const double* tau, double* z,
                                                   double* scratch) {
  using V = typename DVecOf<VW>::type;
  using L = typename LVecOf<VW>::type;
  constexpr std::int64_t W = std::int64_t(VW) * G;  // doubles per index k
  double* lf = scratch;              // e_k / D+_k
  double* ub = scratch + n * W;      // e_{k-1} / D-_k
  double* dp = scratch + 2 * n * W;  // D+_k
  double* zz = scratch + 3 * n * W;  // the vectors, lanes interleaved
  V lambda[G];
  for (int g = 0; g < G; ++g)
    for (int j = 0; j < VW; ++j) lambda[g][j] = lam[std::min(first + g * VW + j, r - 1)];
  // Forward: D+_0 = d_0 - lambda, D+_k = d_k - lambda - e_{k-1} (e_{k-1} / D+_{k-1}).
  {
    V d[G];
    for (int g = 0; g < G; ++g) d[g] = guard<VW>(ds[0] - lambda[g]);
    for (std::int64_t k = 0;; ++k) {
      for (int g = 0; g < G; ++g) store<VW>(dp + k * W + g * VW, d[g]);
      if (k + 1 == n) break;
      for (int g = 0; g < G; ++g) {
        const V l = esc[k] / d[g];
        store<VW>(lf + k * W + g * VW, l);
        d[g] = guard<VW>(ds[k + 1] - lambda[g] - esc[k] * l);
      }
    }
  }
  // Backward: D-_{n-1} = d_{n-1} - lambda, D-_k = d_k - lambda - e_k (e_k / D-_{k+1}); gamma_k =
  // D+_k + D-_k - (d_k - lambda); the twist index t minimises |gamma_k|.
  V best[G];
  L twist[G];
  for (int g = 0; g < G; ++g) {
    best[g] = V{};
    twist[g] = L{};
  }
  {
    V d[G];
    for (int g = 0; g < G; ++g) d[g] = guard<VW>(ds[n - 1] - lambda[g]);
    for (std::int64_t k = n - 1;; --k) {
      for (int g = 0; g < G; ++g) {
        V gamma = load<VW>(dp + k * W + g * VW) + d[g] - (ds[k] - lambda[g]);
        gamma = gamma < 0.0 ? -gamma : gamma;
        if (k == n - 1) {
          best[g] = gamma;
          twist[g] = L{} + k;
        } else {
          const auto better = gamma < best[g];
          best[g] = better ? gamma : best[g];
          twist[g] = better ? L{} + k : twist[g];
        }
      }
      if (k == 0) break;
      for (int g = 0; g < G; ++g) {
        const V u = esc[k - 1] / d[g];
        store<VW>(ub + k * W + g * VW, u);
        d[g] = guard<VW>(ds[k - 1] - lambda[g] - esc[k - 1] * u);
      }
    }
  }
  // z_t = 1; z_k = -(e_k / D+_k) z_{k+1} below t; z_k = -(e_{k-1} / D-_k) z_{k-1} above t.
  V norm2[G];
  for (int g = 0; g < G; ++g) {
    V next = V{};
    for (std::int64_t k = n - 1; k >= 0; --k) {
      const L kk = L{} + k;
      const V below = -load<VW>(lf + k * W + g * VW) * next;  // lf[n - 1] is never used: k < t <= n - 1
      const V zk = kk == twist[g] ? V{} + 1.0 : (kk < twist[g] ? below : V{});
      store<VW>(zz + k * W + g * VW, zk);
      next = zk;
    }
    V prev = load<VW>(zz + g * VW);
    norm2[g] = prev * prev;
    for (std::int64_t k = 1; k < n; ++k) {
      const L kk = L{} + k;
      V zk = load<VW>(zz + k * W + g * VW);
      zk = kk > twist[g] ? -load<VW>(ub + k * W + g * VW) * prev : zk;
      store<VW>(zz + k * W + g * VW, zk);
      norm2[g] += zk * zk;
      prev = zk;
    }
  }
  // Normalise, and check the residual ||T z - lambda z|| (~1e-16 for an accurate eigenpair of
  // the scaled T): a miscounted bisection step or a degenerate twist shows up here.
  bool ok = true;
  for (int g = 0; g < G; ++g) {
    const V inv = 1.0 / vsqrt<VW>(norm2[g]);
    V prev = V{}, residual2 = V{};
    for (std::int64_t k = 0; k < n; ++k) {
      const V zk = load<VW>(zz + k * W + g * VW) * inv;
      store<VW>(zz + k * W + g * VW, zk);
      if (k > 0) {
        const V rk = (ds[k - 1] - lambda[g]) * prev + esc[k - 1] * zk +
                     (k > 1 ? esc[k - 2] * load<VW>(zz + (k - 2) * W + g * VW) : V{});
        residual2 += rk * rk;
      }
      prev = zk;
    }
    const V last = (ds[n - 1] - lambda[g]) * prev + (n > 1 ? esc[n - 2] * load<VW>(zz + (n - 2) * W + g * VW) : V{});
    residual2 += last * last;
    for (int j = 0; j < VW; ++j)
      if (first + g * VW + j < r) ok &= residual2[j] <= 1e-20;  // also false for NaN
  }
  if (!ok) return false;
  for (std::int64_t k = n - 3; k >= 0; --k) {
    if (tau[k] == 0) continue;
    const double* h = a + k * n;  // h[k + 1] = 1, h[i] for i > k + 1
    V w[G];
    for (int g = 0; g < G; ++g) w[g] = V{};
    for (std::int64_t i = k + 1; i < n; ++i)
      for (int g = 0; g < G; ++g) w[g] += load<VW>(zz + i * W + g * VW) * h[i];
    for (int g = 0; g < G; ++g) w[g] *= tau[k];
    for (std::int64_t i = k + 1; i < n; ++i)
      for (int g = 0; g < G; ++g) store<VW>(zz + i * W + g * VW, load<VW>(zz + i * W + g * VW) - w[g] * h[i]);
  }
  for (int g = 0; g < G; ++g)
    for (int j = 0; j < VW; ++j) {
      const std::int64_t col = first + g * VW + j;
      if (col >= r) continue;
      for (std::int64_t k = 0; k < n; ++k) z[col * n + k] = zz[k * W + g * VW + j];
    }
  return true;
}

// Column j of u (n rows) minus its projections on columns 0..j-1, `passes` times (classical
// Gram-Schmidt: the inner products are independent, the column stays in registers); returns its
// norm. `c` holds j doubles.
template <int VW>
[[gnu::always_inline]] inline double orthogonalize(double* u, std::int64_t n, std::int64_t j, int passes, double* c) {
  using V = typename DVecOf<VW>::type;
  double* col = u + j * n;
  for (int pass = 0; pass < passes; ++pass) {
    for (std::int64_t i = 0; i < j; ++i) c[i] = dot<VW>(u + i * n, col, n);
    std::int64_t t = 0;
    for (; t + VW <= n; t += VW) {
      V acc = load<VW>(col + t);
      for (std::int64_t i = 0; i < j; ++i) acc -= c[i] * load<VW>(u + i * n + t);
      store<VW>(col + t, acc);
    }
    for (; t < n; ++t)
      for (std::int64_t i = 0; i < j; ++i) col[t] -= c[i] * u[i * n + t];
  }
  return std::sqrt(dot<VW>(col, col, n));
}

// Work: leading_eigen_work(n) doubles.
template <int VW, int G>
[[gnu::always_inline]] inline bool leading_eigen_impl(double* a, std::int64_t n, std::int64_t r, double* u,
                                                      double* work) {
  if (n <= 0 || r <= 0) return true;
  double* d = work;
  double* e = d + n;
  double* tau = e + n;
  double* ds = tau + n;
  double* e2s = ds + n;
  double* esc = e2s + n;
  double* lam = esc + n;
  double* p = lam + n;
  double* q = p + n;            // n x n: Q for the QL fallback
  double* scratch = q + n * n;  // 4 n VW G
  tridiagonalize<VW>(a, n, d, e, tau, p);

  double tnorm = 0;
  for (std::int64_t k = 0; k < n; ++k) tnorm = std::max({tnorm, std::abs(d[k]), std::abs(e[k])});
  bool ok = tnorm > 0 && std::isfinite(tnorm);
  if (ok) {
    const double inv = 1.0 / tnorm;
    double glo = 0, ghi = 0;
    for (std::int64_t k = 0; k < n; ++k) {
      ds[k] = d[k] * inv;
      esc[k] = k + 1 < n ? e[k] * inv : 0.0;
      e2s[k] = esc[k] * esc[k];
    }
    for (std::int64_t k = 0; k < n; ++k) {
      const double radius = std::abs(esc[k]) + (k > 0 ? std::abs(esc[k - 1]) : 0.0);
      glo = std::min(glo, ds[k] - radius);
      ghi = std::max(ghi, ds[k] + radius);
    }
    glo -= 1e-12;
    ghi += 1e-12;
    constexpr std::int64_t W = std::int64_t(VW) * G;
    // Eigenvalues below kNegligible ||A|| carry no information at double precision; their
    // vectors only need to complete an orthonormal basis.
    std::int64_t significant = 0;
    for (std::int64_t first = 0; first < r && significant == first; first += W) {
      bisect<VW, G>(ds, e2s, n, first, r, glo, ghi, lam);
      while (significant < std::min(r, first + W) && lam[significant] > kNegligible) ++significant;
      if (significant > first) ok &= twisted_vectors<VW, G>(ds, esc, n, first, significant, lam, a, tau, u, scratch);
    }
    // Gram-Schmidt in order of decreasing eigenvalue. Accurate eigenvectors of distinct
    // eigenvalues are orthogonal to ~1e-15 already, so one classical pass (independent inner
    // products, no chain through the column) restores working precision; a vector that
    // collapses onto earlier ones belongs to a cluster of (nearly) equal eigenvalues, which the
    // QL iteration resolves.
    for (std::int64_t j = 0; j < significant && ok; ++j) {
      const double norm = orthogonalize<VW>(u, n, j, 1, scratch);
      ok = norm >= 0.5;  // false for NaN
      const double inv_norm = 1.0 / norm;
      for (std::int64_t k = 0; k < n; ++k) u[j * n + k] *= inv_norm;
    }
    // Completion: the coordinate vector farthest from the span so far (its squared distance is
    // 1 - the squared norm of that row of u, at least 1 - j / n for the best row), orthogonalised
    // twice.
    if (ok && significant < r) {
      double* row_norm2 = scratch + n;
      std::fill(row_norm2, row_norm2 + n, 0.0);
      for (std::int64_t i = 0; i < significant; ++i)
        for (std::int64_t t = 0; t < n; ++t) row_norm2[t] += u[i * n + t] * u[i * n + t];
      for (std::int64_t j = significant; j < r && ok; ++j) {
        double* col = u + j * n;
        const std::int64_t best = std::min_element(row_norm2, row_norm2 + n) - row_norm2;
        std::fill(col, col + n, 0.0);
        col[best] = 1.0;
        const double norm = orthogonalize<VW>(u, n, j, 2, scratch);
        ok = norm >= 0.1;
        const double inv_norm = 1.0 / norm;
        for (std::int64_t t = 0; t < n; ++t) {
          col[t] *= inv_norm;
          row_norm2[t] += col[t] * col[t];
        }
      }
    }
  }
  if (ok) return true;
  // Fallback: all eigenpairs by the QL iteration.
  accumulate_householder<VW>(a, n, tau, q);
  if (!tql2<VW>(d, e, n, q)) return false;
  for (std::int64_t j = 0; j < r; ++j) std::copy_n(q + (n - 1 - j) * n, n, u + j * n);
  return true;
}

}  // namespace

bool leading_eigen_generic(double* a, std::int64_t n, std::int64_t r, double* u, double* work) {
  return leading_eigen_impl<2, 4>(a, n, r, u, work);
}
STRATA_TARGET_AVX2 bool leading_eigen_avx2(double* a, std::int64_t n, std::int64_t r, double* u, double* work) {
  return leading_eigen_impl<4, 2>(a, n, r, u, work);
}
STRATA_TARGET_AVX512 bool leading_eigen_avx512(double* a, std::int64_t n, std::int64_t r, double* u, double* work) {
  return leading_eigen_impl<8, 2>(a, n, r, u, work);
}

}  // namespace strata::tensor::detail
