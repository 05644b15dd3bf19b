#include "runtime/factorization.h"

#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <suitesparse/cholmod.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <dlfcn.h>
#include <mutex>
#include <vector>

// METIS, which CHOLMOD's analysis calls for its ordering, draws from C's rand() after seeding it with srand():
// one process-wide state, so two analyses at once would interleave their draws and change each other's
// orderings (and the last bits of every solution). These two replace glibc's rand() and srand() in the whole
// process (the executable's symbols come first; the link exports them, CMakeLists.txt) by the same generator
// (glibc's random_r, 128 bytes of state, seed 1 until seeded) with one state per thread. A thread that seeds
// and then draws, as METIS and TetGen do, sees exactly the sequence it saw before, whatever other threads do,
// so analyses no longer wait for each other (see analyse()).
namespace {
struct ThreadRandom {
  std::array<char, 128> state{};
  random_data data{};
  ThreadRandom() { ::initstate_r(1, state.data(), state.size(), &data); }
};
ThreadRandom& thread_random() {
  thread_local ThreadRandom r;
  return r;
}
}  // namespace

extern "C" int rand() noexcept {
  std::int32_t x = 0;
  ::random_r(&thread_random().data, &x);
  return x;
}

extern "C" void srand(unsigned seed) noexcept { ::srandom_r(seed, &thread_random().data); }

// OpenBLAS (Debian's libblas.so.3, under CHOLMOD's supernodal kernels) holds one set of kernels per CPU family
// and picks one when it is loaded: the one OPENBLAS_CORETYPE names, or the CPU's. The sets sum in different
// orders, so the factors' last bits, and through them every mesh, would depend on the machine's environment:
// one of our AMD EPYC machines with AVX-512 exports OPENBLAS_CORETYPE=Haswell, another left the choice to
// OpenBLAS (SkylakeX), and the bench mesh and a test's minimum scaled Jacobian (0.377 against 0.633)
// differed. OpenBLAS reads the variable in its initialiser, so this runs from the executable's
// .preinit_array, before any library's initialiser, and rewrites the variable where the environment sets
// it: SkylakeX where the CPU has the AVX-512 those kernels use (OpenBLAS's own choice there; docs/RESULTS.md
// was made with them), else Haswell where it has AVX2 and FMA. The entry is replaced in the process's initial
// environment block itself: libc adopts that block after this runs, so setenv() here would be lost.
namespace {
void pin_blas_kernels(int, char**, char** env) {
  const char* kernels = polyhex::blas_kernels_for_this_cpu();
  if (!env || !kernels) return;
  static char skylakex[] = "OPENBLAS_CORETYPE=SkylakeX", haswell[] = "OPENBLAS_CORETYPE=Haswell";
  char* entry = std::strcmp(kernels, "SkylakeX") == 0 ? skylakex : haswell;
  constexpr char kName[] = "OPENBLAS_CORETYPE=";
  for (char** e = env; *e; ++e)
    if (std::strncmp(*e, kName, sizeof(kName) - 1) == 0) *e = entry;
}
[[gnu::section(".preinit_array"), gnu::used]] void (*const pin_blas_kernels_at_start)(int, char**,
                                                                                      char**) = pin_blas_kernels;
}  // namespace

namespace polyhex {

const char* blas_kernels_for_this_cpu() {
  __builtin_cpu_init();  // pin_blas_kernels runs before the constructors that would do it
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512cd"))
    return "SkylakeX";
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
  return nullptr;
}

bool analyses_run_concurrently() {
  static const bool ours = ::dlsym(RTLD_DEFAULT, "rand") == reinterpret_cast<void*>(&::rand);
  return ours;
}

namespace {

using Clock = std::chrono::steady_clock;

/// Runs the BLAS under CHOLMOD on one thread. A multi-threaded OpenBLAS splits the supernodal
/// kernels (dsyrk/dgemm/dtrsm) by its own thread count, so the factor's last bits could depend on the
/// machine; and its threads would compete with TBB's workers (the parallelism of polyhex is TBB's:
/// stages, columns). Looked up at run time: the BLAS behind libblas.so.3 need not be OpenBLAS (then
/// nothing is done; reference BLAS is single-threaded anyway).
void single_threaded_blas() {
  static std::once_flag once;
  std::call_once(once, [] {
    using SetThreads = void (*)(int);
    if (auto f = reinterpret_cast<SetThreads>(::dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(1);
  });
}

/// Makes every OpenMP parallel region the calling thread meets run as a team of one (OpenMP's
/// max-active-levels 0, a setting of the calling thread). Debian's CHOLMOD clears and fills each supernode in
/// OpenMP loops with teams of four threads whatever OMP_NUM_THREADS says; from two TBB workers at once (the
/// rotation stage factors two matrices side by side, the PolyCube map its three axes) that is eight threads on
/// two cores, most of the time spent waking them: the bench's two rotation factorizations took 0.80 s with the
/// teams, 0.41 s without. The loops copy and clear entries, so the factor is the same bits. Called on the
/// thread that is about to call CHOLMOD; looked up at run time (nothing is done without libgomp).
void serial_openmp() {
  using SetLevels = void (*)(int);
  static const auto set = reinterpret_cast<SetLevels>(::dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  if (set) set(0);
}

/// A cholmod_common set up the same way everywhere: supernodal LL^T, no printing.
struct Common {
  cholmod_common c;
  Common() {
    single_threaded_blas();
    cholmod_start(&c);
    c.supernodal = CHOLMOD_SUPERNODAL;  // always supernodal: BLAS-3 kernels (OpenBLAS) for 3D meshes
    c.final_ll = 1;
    c.print = 0;  // errors become SolverError, CHOLMOD prints nothing
    // METIS nested dissection only: on tet-mesh Laplacians (~50k vertices) it gives ~25 % less
    // factor work than AMD, and the default (AMD, then METIS when AMD fills in badly) pays for both.
    c.nmethods = 1;
    c.method[0].ordering = CHOLMOD_METIS;
  }
  ~Common() { cholmod_finish(&c); }
  Common(const Common&) = delete;
  Common& operator=(const Common&) = delete;
};

/// Solve workspace of one thread: its own common plus reusable solution and work vectors.
struct Worker {
  Common common;
  cholmod_dense* X = nullptr;
  cholmod_dense* Y = nullptr;
  cholmod_dense* E = nullptr;
  ~Worker() {
    cholmod_free_dense(&X, &common.c);
    cholmod_free_dense(&Y, &common.c);
    cholmod_free_dense(&E, &common.c);
  }
};

/// A non-owning cholmod_dense view of a column-major block of doubles.
cholmod_dense dense_view(const double* data, size_t rows, size_t cols) {
  cholmod_dense d;
  d.nrow = rows;
  d.ncol = cols;
  d.nzmax = rows * cols;
  d.d = rows;
  d.x = const_cast<double*>(data);  // CHOLMOD reads B only
  d.z = nullptr;
  d.xtype = CHOLMOD_REAL;
  d.dtype = CHOLMOD_DOUBLE;
  return d;
}

/// A itself when compressed, else a compressed copy of it stored in `copy`.
const Eigen::SparseMatrix<double>* compressed(const Eigen::SparseMatrix<double>& A, Eigen::SparseMatrix<double>& copy) {
  if (A.isCompressed()) return &A;
  copy = A;
  copy.makeCompressed();
  return &copy;
}

const char* ordering_name(int o) {
  switch (o) {
    case CHOLMOD_NATURAL:
      return "natural";
    case CHOLMOD_GIVEN:
      return "given";
    case CHOLMOD_AMD:
      return "amd";
    case CHOLMOD_METIS:
      return "metis";
    case CHOLMOD_NESDIS:
      return "nesdis";
    case CHOLMOD_COLAMD:
      return "colamd";
    case CHOLMOD_POSTORDERED:
      return "postordered";
    default:
      return "unknown";
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

FactorizationStats& FactorizationStats::operator+=(const FactorizationStats& o) {
  analyses += o.analyses;
  factorizations += o.factorizations;
  solves += o.solves;
  solve_calls += o.solve_calls;
  analyse_seconds += o.analyse_seconds;
  factor_seconds += o.factor_seconds;
  solve_seconds += o.solve_seconds;
  return *this;
}

void FactorizationStats::merge_into(nlohmann::json& metrics) const {
  auto add = [&metrics](const char* key, double v, bool integer) {
    double old = metrics.contains(key) && metrics[key].is_number() ? metrics[key].get<double>() : 0.0;
    if (integer)
      metrics[key] = static_cast<long>(std::llround(old + v));
    else
      metrics[key] = old + v;
  };
  add("analyses", analyses, true);
  add("factorizations", factorizations, true);
  add("solves", static_cast<double>(solves), true);
  add("analyse_seconds", analyse_seconds, false);
  add("factor_seconds", factor_seconds, false);
  add("solve_seconds", solve_seconds, false);
}

// ---------------------------------------------------------------------------------------------

struct CholmodFactorization::Impl {
  Common common;
  cholmod_factor* L = nullptr;
  bool is_factored = false;
  long n = 0;
  std::vector<int> outer, inner;  // the analysed pattern, to check factor() inputs
  FactorizationStats stats;
  Worker main_worker;  // workspace of the multi-column and single-column solves
  tbb::enumerable_thread_specific<std::unique_ptr<Worker>> workers;

  ~Impl() {
    if (L) cholmod_free_factor(&L, &common.c);
  }

  /// A non-owning view of A, stype -1 (lower triangle read). A must be compressed.
  static cholmod_sparse view(const Eigen::SparseMatrix<double>& A) {
    cholmod_sparse s;
    s.nrow = static_cast<size_t>(A.rows());
    s.ncol = static_cast<size_t>(A.cols());
    s.nzmax = static_cast<size_t>(A.nonZeros());
    s.p = const_cast<int*>(A.outerIndexPtr());
    s.i = const_cast<int*>(A.innerIndexPtr());
    s.nz = nullptr;
    s.x = const_cast<double*>(A.valuePtr());
    s.z = nullptr;
    s.stype = -1;
    s.itype = CHOLMOD_INT;
    s.xtype = CHOLMOD_REAL;
    s.dtype = CHOLMOD_DOUBLE;
    s.sorted = 1;
    s.packed = 1;
    return s;
  }

  void check_solvable(long rows) const {
    if (!is_factored) throw SolverError("Cholesky solve: no valid factorization (call factor() first)");
    if (rows != n)
      throw SolverError("Cholesky solve: right-hand side has " + std::to_string(rows) + " rows, matrix has " +
                        std::to_string(n));
  }

  static void check_finite(const double* x, long count, const char* what) {
    for (long i = 0; i < count; ++i)
      if (!std::isfinite(x[i]))
        throw SolverError(std::string("Cholesky ") + what + ": non-finite value at entry " + std::to_string(i));
  }

  /// Solve the columns [c0, c0+k) of B with one cholmod_solve2 call into X.
  void solve_block(Worker& w, const Eigen::MatrixXd& B, Eigen::MatrixXd& X, long c0, long k) {
    cholmod_dense b = dense_view(B.data() + c0 * n, static_cast<size_t>(n), static_cast<size_t>(k));
    serial_openmp();
    if (!cholmod_solve2(CHOLMOD_A, L, &b, nullptr, &w.X, nullptr, &w.Y, &w.E, &w.common.c))
      throw SolverError("Cholesky solve: CHOLMOD failed (status " + std::to_string(w.common.c.status) + ")");
    std::memcpy(X.data() + c0 * n, w.X->x, sizeof(double) * static_cast<size_t>(n * k));
  }
};

CholmodFactorization::CholmodFactorization() : impl_(std::make_unique<Impl>()) {}
CholmodFactorization::CholmodFactorization(const Eigen::SparseMatrix<double>& A) : CholmodFactorization() { factor(A); }
CholmodFactorization::~CholmodFactorization() = default;
CholmodFactorization::CholmodFactorization(CholmodFactorization&&) noexcept = default;
CholmodFactorization& CholmodFactorization::operator=(CholmodFactorization&&) noexcept = default;

void CholmodFactorization::analyse(const Eigen::SparseMatrix<double>& A_in) {
  auto t0 = Clock::now();
  Impl& m = *impl_;
  if (A_in.rows() != A_in.cols())
    throw SolverError("Cholesky analysis: matrix is " + std::to_string(A_in.rows()) + " by " +
                      std::to_string(A_in.cols()) + ", not square");
  if (A_in.rows() == 0) throw SolverError("Cholesky analysis: matrix is empty");
  Eigen::SparseMatrix<double> copy;
  const Eigen::SparseMatrix<double>* A = compressed(A_in, copy);
  long lower = 0, upper = 0;
  for (int j = 0; j < A->outerSize(); ++j)
    for (int p = A->outerIndexPtr()[j]; p < A->outerIndexPtr()[j + 1]; ++p) {
      int i = A->innerIndexPtr()[p];
      lower += i > j;
      upper += i < j;
    }
  if (lower == 0 && upper > 0)
    throw SolverError(
        "Cholesky analysis: matrix holds only its upper triangle; pass the lower triangle or the full "
        "symmetric matrix");

  if (m.L) cholmod_free_factor(&m.L, &m.common.c);
  m.is_factored = false;
  cholmod_sparse s = Impl::view(*A);
  {
    // METIS (CHOLMOD's fill-reducing ordering) seeds and draws from C's rand(). With the per-thread rand()
    // above in place, analyses run side by side; were it not (a link that does not export it), two analyses
    // at once would interleave their draws and change each other's orderings, so they would wait in turn.
    static std::mutex analyse_mutex;
    std::unique_lock<std::mutex> lock(analyse_mutex, std::defer_lock);
    if (!analyses_run_concurrently()) lock.lock();
    serial_openmp();
    m.L = cholmod_analyze(&s, &m.common.c);
  }
  if (!m.L || m.common.c.status < CHOLMOD_OK)
    throw SolverError("Cholesky analysis: CHOLMOD failed (status " + std::to_string(m.common.c.status) + ")");
  m.n = A->rows();
  m.outer.assign(A->outerIndexPtr(), A->outerIndexPtr() + A->outerSize() + 1);
  m.inner.assign(A->innerIndexPtr(), A->innerIndexPtr() + A->nonZeros());
  m.stats.analyses += 1;
  m.stats.analyse_seconds += seconds_since(t0);
}

CholmodFactorization CholmodFactorization::share_analysis() const {
  const Impl& m = *impl_;
  if (!m.L) throw SolverError("Cholesky: no analysis to share (call analyse() first)");
  CholmodFactorization out;
  Impl& o = *out.impl_;
  o.L = cholmod_copy_factor(m.L, &o.common.c);
  if (!o.L)
    throw SolverError("Cholesky: CHOLMOD cannot copy the analysis (status " + std::to_string(o.common.c.status) + ")");
  o.n = m.n;
  o.outer = m.outer;
  o.inner = m.inner;
  return out;
}

void CholmodFactorization::factor(const Eigen::SparseMatrix<double>& A_in) {
  Impl& m = *impl_;
  if (!m.L) analyse(A_in);
  auto t0 = Clock::now();
  Eigen::SparseMatrix<double> copy;
  const Eigen::SparseMatrix<double>* A = compressed(A_in, copy);
  const bool same_pattern = A->rows() == m.n && A->cols() == m.n &&
                            static_cast<size_t>(A->nonZeros()) == m.inner.size() &&
                            std::equal(m.outer.begin(), m.outer.end(), A->outerIndexPtr()) &&
                            std::equal(m.inner.begin(), m.inner.end(), A->innerIndexPtr());
  if (!same_pattern)
    throw SolverError("Cholesky factorization: the matrix pattern differs from the analysed one (" +
                      std::to_string(A->rows()) + " by " + std::to_string(A->cols()) + ", " +
                      std::to_string(A->nonZeros()) + " entries; analysed " + std::to_string(m.n) + " by " +
                      std::to_string(m.n) + ", " + std::to_string(m.inner.size()) + " entries)");
  Impl::check_finite(A->valuePtr(), A->nonZeros(), "factorization: matrix has a");
  m.is_factored = false;
  cholmod_sparse s = Impl::view(*A);
  serial_openmp();
  const int ok = cholmod_factorize(&s, m.L, &m.common.c);
  m.stats.factor_seconds += seconds_since(t0);
  if (m.common.c.status == CHOLMOD_NOT_POSDEF)
    throw SolverError("Cholesky factorization: matrix is not positive definite (pivot " + std::to_string(m.L->minor) +
                      " of " + std::to_string(m.n) + " is not positive)");
  if (!ok || m.common.c.status < CHOLMOD_OK)
    throw SolverError("Cholesky factorization: CHOLMOD failed (status " + std::to_string(m.common.c.status) + ")");
  m.is_factored = true;
  m.stats.factorizations += 1;
}

Eigen::VectorXd CholmodFactorization::solve(const Eigen::VectorXd& b) {
  Eigen::MatrixXd B = b;
  Eigen::MatrixXd X = solve(B, SolveMode::MultiColumn);
  return X.col(0);
}

Eigen::MatrixXd CholmodFactorization::solve(const Eigen::MatrixXd& B, SolveMode mode) {
  Impl& m = *impl_;
  m.check_solvable(B.rows());
  Impl::check_finite(B.data(), B.size(), "solve: right-hand side has a");
  auto t0 = Clock::now();
  const long k = B.cols();
  Eigen::MatrixXd X(m.n, k);
  if (k == 0) return X;
  if (mode == SolveMode::MultiColumn || k == 1) {
    m.solve_block(m.main_worker, B, X, 0, k);
  } else {
    // Concurrent cholmod_solve2 calls only read the factor; every thread owns its common and its
    // X/Y/E workspace, so nothing is shared for writing.
    tbb::parallel_for(tbb::blocked_range<long>(0, k, 1), [&](const tbb::blocked_range<long>& r) {
      auto& w = m.workers.local();
      if (!w) w = std::make_unique<Worker>();
      for (long c = r.begin(); c < r.end(); ++c) m.solve_block(*w, B, X, c, 1);
    });
  }
  m.stats.solves += k;
  m.stats.solve_calls += 1;
  m.stats.solve_seconds += seconds_since(t0);
  return X;
}

bool CholmodFactorization::factored() const { return impl_->is_factored; }
long CholmodFactorization::rows() const { return impl_->n; }
double CholmodFactorization::factor_nonzeros() const { return impl_->L ? impl_->common.c.lnz : 0.0; }
bool CholmodFactorization::supernodal() const { return impl_->L && impl_->L->is_super; }
std::string CholmodFactorization::ordering() const { return impl_->L ? ordering_name(impl_->L->ordering) : "none"; }
const FactorizationStats& CholmodFactorization::stats() const { return impl_->stats; }

}  // namespace polyhex
