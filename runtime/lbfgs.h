/// @file lbfgs.h
/// @brief Limited-memory BFGS (two-loop recursion, memory 8) with a backtracking Armijo line search, for
/// the foldover-free energies of the untangling steps (the hex mesh in nodes/optimize, the PolyCube map
/// in nodes/position_deform). The energies are finite everywhere (regularised determinant), so the line
/// search only needs finite values; it halves the step up to `max_halvings` times.
#pragma once

#include "runtime/cancel.h"

#include <Eigen/Core>

#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <type_traits>
#include <vector>

namespace polyhex {

struct LbfgsOptions {
  int iterations = 200;     ///< at most this many iterations
  double gradient_tol = 0;  ///< stop (Stalled) when max |g_i| <= this
  double first_move = 1;    ///< a steepest-descent step moves no unknown by more than this
  int max_halvings = 40;    ///< the line search gives up (Stalled) after halving the step this many times
  /// If set: applies M^-1 in place, M a symmetric positive definite approximation of the Hessian; the
  /// two-loop recursion's initial inverse Hessian is then γ M^-1 (γ = s'y / y'M^-1 y of the newest pair)
  /// instead of γ I (Nocedal and Wright, Numerical Optimization, 2nd ed., §7.2).
  std::function<void(Eigen::VectorXd&)> precondition;
};

enum class LbfgsEnd {
  Iterations,  ///< used all iterations
  Converged,   ///< the energy decreased by less than 1e-12 (relative)
  Stalled,     ///< gradient below tolerance, or no step decreased the energy
  Stopped      ///< `stop` returned true
};

/// Minimises f from x (updated in place). `f(x, g)` returns the energy at x and, when g is not null, writes
/// its gradient (g has x's size). Every trial of the line search asks for the gradient: the accepted one
/// needs it, and an energy that can tell early that a trial fails need not finish it. Such an energy takes
/// a third argument, `f(x, g, accept_up_to)`: the trials pass the largest value they accept (the first call
/// passes +inf), and f may return any value above that (+inf) as soon as it knows its value is above it,
/// leaving g unset: the trial is rejected either way, so the iterates are those of the value computed to
/// the end. (On the map's polish, whose barrier rejects a third of the trials, this beats trials without the
/// gradient and the accepted point evaluated again with it: docs/speed.md.) `stop(done, x, after_step)` is
/// asked before every iteration (after_step false) and after each accepted step (after_step true, done
/// counting this step), with done = the iterations done; true ends the run. `count` (if not null) is
/// incremented per iteration. Checks SIGINT/SIGTERM per iteration. \throw Interrupted (runtime/cancel.h)
template <class Energy, class Stop>
LbfgsEnd lbfgs_minimize(Eigen::VectorXd& x, Energy&& f, const LbfgsOptions& o, Stop&& stop, long* count = nullptr) {
  using VecX = Eigen::VectorXd;
  constexpr int kMemory = 8;
  constexpr double kNoBound = std::numeric_limits<double>::infinity();
  // with a three-argument energy, every other call passes no bound
  auto full = [&f](const VecX& y, VecX* grad) {
    if constexpr (std::is_invocable_v<Energy&, const VecX&, VecX*, double>)
      return f(y, grad, kNoBound);
    else
      return f(y, grad);
  };
  std::deque<VecX> S, Y;
  std::deque<double> SY;  // s'y of each pair, taken once (y's has its bits: the same sum of the same products)
  VecX g(x.size()), gn(x.size());
  double e = full(x, &g);
  for (int it = 0; it < o.iterations; ++it) {
    if (stop(it, x, false)) return LbfgsEnd::Stopped;
    throw_if_interrupted();
    if (count) ++*count;
    const double gmax = g.lpNorm<Eigen::Infinity>();
    if (!(gmax > o.gradient_tol)) return LbfgsEnd::Stalled;
    VecX d = -g;
    std::vector<double> alpha(S.size());
    for (int i = int(S.size()) - 1; i >= 0; --i) {
      alpha[size_t(i)] = S[size_t(i)].dot(d) / SY[size_t(i)];
      d -= alpha[size_t(i)] * Y[size_t(i)];
    }
    if (o.precondition) {
      o.precondition(d);
      if (!S.empty()) {
        VecX my = Y.back();
        o.precondition(my);
        d *= SY.back() / Y.back().dot(my);
      }
    } else if (!S.empty()) {
      d *= SY.back() / Y.back().squaredNorm();
    }
    for (size_t i = 0; i < S.size(); ++i) {
      const double beta = Y[i].dot(d) / SY[i];
      d += (alpha[i] - beta) * S[i];
    }
    double slope = g.dot(d);
    if (!(slope < 0)) {  // not a descent direction: restart from steepest descent
      S.clear();
      Y.clear();
      SY.clear();
      d = -g;
      if (o.precondition) o.precondition(d);
      slope = g.dot(d);
    }
    double step = S.empty() ? std::min(1.0, o.first_move / d.lpNorm<Eigen::Infinity>()) : 1.0;
    VecX xn;
    double en = e;
    bool ok = false;
    for (int k = 0; k < o.max_halvings; ++k, step *= 0.5) {
      xn = x + step * d;
      const double accept_up_to = e + 1e-4 * step * slope;
      if constexpr (std::is_invocable_v<Energy&, const VecX&, VecX*, double>)
        en = f(xn, &gn, accept_up_to);
      else
        en = f(xn, &gn);
      if (std::isfinite(en) && en <= accept_up_to) {
        ok = true;
        break;
      }
    }
    if (!ok) return LbfgsEnd::Stalled;
    VecX s = xn - x, y = gn - g;
    x = xn;
    g = gn;
    const bool converged = e - en <= 1e-12 * std::max(1.0, std::abs(e));
    e = en;
    const double sy = s.dot(y);
    if (sy > 1e-16 * s.norm() * y.norm()) {
      S.push_back(std::move(s));
      Y.push_back(std::move(y));
      SY.push_back(sy);
      if (int(S.size()) > kMemory) S.pop_front(), Y.pop_front(), SY.pop_front();
    }
    if (converged) return LbfgsEnd::Converged;
    if (stop(it + 1, x, true)) return LbfgsEnd::Stopped;
  }
  return LbfgsEnd::Iterations;
}

}  // namespace polyhex
