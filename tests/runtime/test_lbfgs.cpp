// L-BFGS helper: analytic minimisers, the stop callback's contract, the line search's give-up.
#include "runtime/lbfgs.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

using namespace polyhex;

TEST_CASE("lbfgs finds the minimiser of an ill-conditioned quadratic and of Rosenbrock's function", "[lbfgs]") {
  // f = Σ a_i (x_i - i)², a from 1 to 1e4: minimiser x_i = i
  const int n = 20;
  auto quad = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    double f = 0;
    for (int i = 0; i < n; ++i) {
      const double a = std::pow(10.0, 4.0 * i / (n - 1)), d = x[i] - i;
      f += a * d * d;
      if (g) (*g)[i] = 2 * a * d;
    }
    return f;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  LbfgsOptions o;
  o.iterations = 2000;
  o.gradient_tol = 1e-10;
  long count = 0;
  const LbfgsEnd end = lbfgs_minimize(
      x, quad, o, [](int, const Eigen::VectorXd&, bool) { return false; }, &count);
  CHECK(end != LbfgsEnd::Iterations);
  for (int i = 0; i < n; ++i) CHECK(x[i] == Approx(double(i)).margin(1e-5));
  CHECK(count > 0);
  CHECK(count < 2000);

  auto rosen = [](const Eigen::VectorXd& y, Eigen::VectorXd* g) {
    const double a = 1 - y[0], b = y[1] - y[0] * y[0];
    if (g) (*g) << -2 * a - 400 * y[0] * b, 200 * b;
    return a * a + 100 * b * b;
  };
  Eigen::VectorXd r(2);
  r << -1.2, 1.0;
  o.first_move = 0.1;
  lbfgs_minimize(r, rosen, o, [](int, const Eigen::VectorXd&, bool) { return false; });
  CHECK(r[0] == Approx(1.0).margin(1e-4));
  CHECK(r[1] == Approx(1.0).margin(1e-4));
}

TEST_CASE("lbfgs asks stop before each iteration and after each step, and ends when it says so", "[lbfgs]") {
  // ill-conditioned: not solved in 3 steps
  const Eigen::Vector3d a(1.0, 30.0, 900.0);
  auto f = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    if (g) *g = 2 * a.cwiseProduct(x);
    return x.dot(a.cwiseProduct(x));
  };
  Eigen::VectorXd x = Eigen::VectorXd::Constant(3, 5.0);
  std::vector<std::pair<int, bool>> calls;
  LbfgsOptions o;
  o.iterations = 100;
  long count = 0;
  const LbfgsEnd end = lbfgs_minimize(
      x, f, o,
      [&](int done, const Eigen::VectorXd&, bool after) {
        calls.push_back({done, after});
        return after && done == 3;
      },
      &count);
  CHECK(end == LbfgsEnd::Stopped);
  CHECK(count == 3);
  REQUIRE(calls.size() == 6);
  for (int k = 0; k < 3; ++k) {
    CHECK(calls[size_t(2 * k)] == std::make_pair(k, false));
    CHECK(calls[size_t(2 * k + 1)] == std::make_pair(k + 1, true));
  }
}

TEST_CASE("lbfgs stalls, x unchanged, when no step decreases the energy within max_halvings", "[lbfgs]") {
  // the gradient points uphill: no step along -g lowers f
  auto liar = [](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    if (g) *g = -2 * x;
    return x.squaredNorm();
  };
  Eigen::VectorXd x = Eigen::VectorXd::Constant(2, 1.0);
  const Eigen::VectorXd x0 = x;
  int evals = 0;
  LbfgsOptions o;
  o.max_halvings = 5;
  const LbfgsEnd end = lbfgs_minimize(
      x,
      [&](const Eigen::VectorXd& y, Eigen::VectorXd* g) {
        ++evals;
        return liar(y, g);
      },
      o, [](int, const Eigen::VectorXd&, bool) { return false; });
  CHECK(end == LbfgsEnd::Stalled);
  CHECK(x == x0);
  CHECK(evals == 1 + 5);  // the start, then one per halving
}

TEST_CASE("lbfgs with an energy that takes the acceptance bound: the same iterates when it gives up above it",
          "[lbfgs]") {
  // a barrier (-log) along each axis with its minimiser close to it: many trials leave the domain. The bounded
  // energy stops summing at the first term above the bound (each term is positive: the sum is at least any).
  long cut = 0, bounded_calls = 0;
  auto term = [](const Eigen::VectorXd& x, Eigen::Index i, Eigen::VectorXd* g) {
    const double a = 1.0 + double(i * i), t = 1.0 - x[i];
    if (!(t > 0)) return std::numeric_limits<double>::infinity();
    if (g) (*g)[i] = 2 * a * x[i] + 1.0 / t - 30.0;
    return a * x[i] * x[i] - std::log(t) - 30.0 * x[i] + 40.0;
  };
  auto f2 = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    double e = 0;
    for (Eigen::Index i = 0; i < x.size(); ++i) e += term(x, i, g);
    return e;
  };
  auto f3 = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g, double accept_up_to) {
    const bool bounded = accept_up_to < std::numeric_limits<double>::infinity();
    bounded_calls += bounded;
    CHECK((!bounded || g != nullptr));  // the trials ask for the gradient too
    double e = 0;
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      const double t = term(x, i, g);
      if (bounded && !(t <= accept_up_to)) return ++cut, std::numeric_limits<double>::infinity();
      e += t;
    }
    return e;
  };
  LbfgsOptions o;
  o.iterations = 60;
  o.first_move = 1.0;
  auto never = [](int, const Eigen::VectorXd&, bool) { return false; };
  Eigen::VectorXd a = Eigen::VectorXd::Constant(12, -2.0), b = a;
  long it_a = 0, it_b = 0;
  lbfgs_minimize(a, f2, o, never, &it_a);
  lbfgs_minimize(b, f3, o, never, &it_b);
  CHECK(it_a == it_b);
  CHECK(a == b);  // bit for bit
  CHECK(bounded_calls > it_b);
  CHECK(cut > 0);  // some trials were given up early
}

TEST_CASE("lbfgs with the exact Hessian as preconditioner solves an ill-conditioned quadratic at once", "[lbfgs]") {
  // f = Σ a_i (x_i - i)², a from 1 to 1e6; M = diag(2 a): the preconditioned steepest descent is Newton's step
  const int n = 30;
  Eigen::VectorXd a(n);
  for (int i = 0; i < n; ++i) a[i] = std::pow(10.0, 6.0 * i / (n - 1));
  const Eigen::VectorXd target = Eigen::VectorXd::LinSpaced(n, 0, n - 1);
  auto quad = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    const Eigen::VectorXd d = x - target;
    if (g) *g = 2 * a.cwiseProduct(d);
    return d.dot(a.cwiseProduct(d));
  };
  auto error_after = [&](int iterations, bool precondition) {  // max |x_i - i| after that many iterations
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    LbfgsOptions o;
    o.iterations = iterations;
    o.first_move = 1e9;  // let the first step be the preconditioned one
    if (precondition) o.precondition = [&](Eigen::VectorXd& d) { d = d.cwiseQuotient(2 * a); };
    lbfgs_minimize(x, quad, o, [](int, const Eigen::VectorXd&, bool) { return false; });
    return (x - target).lpNorm<Eigen::Infinity>();
  };
  CHECK(error_after(2, true) < 1e-9);
  CHECK(error_after(2, false) > 1.0);
  CHECK(error_after(20, false) > 1e-3);
}
