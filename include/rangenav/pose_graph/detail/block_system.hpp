#pragma once
// A symmetric positive (semi)definite linear system with dense B×B blocks over the nodes of a
// graph, factored by Eigen's SimplicialLDLT: the normal equations of the pose graph (B = 3 or 6)
// and of its linear initialisation (B = D).
//
// The sparsity pattern is fixed by the graph's edges, so it is built once: the nodes are ordered
// by approximate minimum degree (AMD, Amestoy, Davis, Duff 1996) on the block graph, which is
// B² times smaller than the scalar pattern and keeps each block's variables together; the upper
// triangle is stored in that order, so SimplicialLDLT runs with its natural ordering and factors
// the assembled matrix in place (no permuted copy per iteration); its symbolic analysis is done
// once per pattern. Each block knows where its columns start in the value array, so assembly is
// a sequence of contiguous additions, with no triplets and no sort.
//
// Where SuiteSparse's CHOLMOD is available (RANGENAV_HAVE_CHOLMOD, target rangenav::cholmod), a
// pattern whose factorisation costs many flops per entry of L (CHOLMOD's own test for when a
// supernodal factorisation pays: flops ≥ supernodal_switch·nnz(L), typical of large 3D graphs,
// judged on the block graph) is factored by CHOLMOD's supernodal Cholesky instead, with
// CHOLMOD's ordering; both are exact, so the results agree to rounding.

#include <Eigen/Core>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#ifdef RANGENAV_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

namespace rangenav {

/// Which sparse Cholesky factorisation solves the pose graph's normal equations.
enum class SparseBackend {
  automatic,  ///< CHOLMOD's supernodal factorisation where it pays and is available, else Eigen
  eigen,      ///< Eigen's SimplicialLDLT (header-only)
  cholmod     ///< CHOLMOD's supernodal Cholesky (needs RANGENAV_HAVE_CHOLMOD)
};

/// True when rangenav was built with CHOLMOD (RANGENAV_HAVE_CHOLMOD).
inline constexpr bool have_cholmod =
#ifdef RANGENAV_HAVE_CHOLMOD
    true;
#else
    false;
#endif

}  // namespace rangenav

namespace rangenav::detail {

#ifdef RANGENAV_HAVE_CHOLMOD
// CHOLMOD factors double-precision matrices only; other scalars always use Eigen.
struct NoCholmod {};
template <class Scalar>
struct CholmodFor {
  using type = NoCholmod;
};
template <>
struct CholmodFor<double> {
  using type =
      Eigen::CholmodDecomposition<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Upper>;
};
#endif

/// A fill-reducing order of the nodes: approximate minimum degree (Eigen's AMD) on the graph of
/// `nodes` nodes and the edges `pairs`; position[i] is node i's place in the order.
inline std::vector<std::size_t> block_ordering(
    std::size_t nodes, const std::vector<std::pair<std::size_t, std::size_t>>& pairs) {
  std::vector<std::size_t> position(nodes);
  if (nodes == 0) return position;
  // The lower triangle of the adjacency with its diagonal; Eigen's AMD symmetrises it.
  std::vector<Eigen::Triplet<double, int>> entries;
  entries.reserve(pairs.size() + nodes);
  for (std::size_t i = 0; i < nodes; ++i)
    entries.emplace_back(static_cast<int>(i), static_cast<int>(i), 1.0);
  for (const auto& [i, j] : pairs)
    entries.emplace_back(static_cast<int>(std::max(i, j)), static_cast<int>(std::min(i, j)), 1.0);
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> graph(static_cast<Eigen::Index>(nodes),
                                                          static_cast<Eigen::Index>(nodes));
  graph.setFromTriplets(entries.begin(), entries.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
  Eigen::AMDOrdering<int> amd;
  amd(graph, order);  // order.indices()[new] = old
  for (std::size_t k = 0; k < nodes; ++k)
    position[static_cast<std::size_t>(order.indices()[static_cast<Eigen::Index>(k)])] = k;
  return position;
}

template <class Scalar, int B>
class BlockSystem {
 public:
  using Block = Eigen::Matrix<Scalar, B, B>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  using SparseMatrix = Eigen::SparseMatrix<Scalar, Eigen::ColMajor, int>;

  BlockSystem() = default;
  // Eigen's solvers cannot be copied: a copy analyses the copied pattern afresh.
  BlockSystem(const BlockSystem& other)
      : nodes_(other.nodes_),
        position_(other.position_),
        diagonal_(other.diagonal_),
        off_diagonal_(other.off_diagonal_),
        matrix_(other.matrix_),
        diagonal_values_(other.diagonal_values_),
        floor_(other.floor_),
        rhs_(other.rhs_),
        use_cholmod_(other.use_cholmod_) {
    if (matrix_.rows() > 0)
      analyze(use_cholmod_ ? SparseBackend::cholmod : SparseBackend::eigen, {});
  }
  BlockSystem& operator=(const BlockSystem& other) {
    if (this != &other) {
      BlockSystem copy(other);
      *this = std::move(copy);
    }
    return *this;
  }
  BlockSystem(BlockSystem&& other) noexcept = default;
  BlockSystem& operator=(BlockSystem&& other) noexcept = default;
  ~BlockSystem() = default;

  /// Builds the pattern of `nodes` diagonal blocks and the off-diagonal blocks of `pairs` (node
  /// indices, i ≠ j; repeated pairs share one block), with node i's block at `position[i]` (a
  /// permutation, e.g. block_ordering's). Afterwards off-diagonal slot k is the block of
  /// pairs[k].
  void build(std::size_t nodes, const std::vector<std::pair<std::size_t, std::size_t>>& pairs,
             const std::vector<std::size_t>& position,
             SparseBackend backend = SparseBackend::automatic) {
    nodes_ = nodes;
    position_ = position;

    // Block columns in the new order: rows (block indices ≤ column) sorted, diagonal last.
    std::vector<std::vector<std::size_t>> rows(nodes);
    for (std::size_t i = 0; i < nodes; ++i)
      rows[position_[i]].push_back(position_[i]);
    for (const auto& [i, j] : pairs) {
      const std::size_t a = position_[i], b = position_[j];
      rows[std::max(a, b)].push_back(std::min(a, b));
    }
    for (auto& column : rows) {
      std::sort(column.begin(), column.end());
      column.erase(std::unique(column.begin(), column.end()), column.end());
    }

    // Scalar CSC pattern of the upper triangle.
    const auto n = static_cast<Eigen::Index>(nodes * B);
    matrix_.resize(n, n);
    std::vector<int> column_sizes(static_cast<std::size_t>(n));
    for (std::size_t bc = 0; bc < nodes; ++bc)
      for (int c = 0; c < B; ++c)
        column_sizes[bc * B + static_cast<std::size_t>(c)] =
            static_cast<int>((rows[bc].size() - 1) * B) + c + 1;
    // An empty system (no free node) stays as resize() left it: Eigen's reserve() of no columns
    // leaves makeCompressed() reading past its index arrays.
    if (n > 0) {
      matrix_.reserve(column_sizes);
      for (std::size_t bc = 0; bc < nodes; ++bc)
        for (int c = 0; c < B; ++c) {
          const auto col = static_cast<Eigen::Index>(bc * B) + c;
          for (const std::size_t br : rows[bc]) {
            const int last = br == bc ? c : B - 1;
            for (int r = 0; r <= last; ++r)
              matrix_.insert(static_cast<Eigen::Index>(br * B) + r, col) = Scalar(0);
          }
        }
      matrix_.makeCompressed();
    }

    // Where every block starts: column start + rank of the block row within the block column.
    const auto rank_in = [&](std::size_t br, std::size_t bc) {
      const auto& column = rows[bc];
      return static_cast<int>(std::lower_bound(column.begin(), column.end(), br) - column.begin());
    };
    diagonal_.resize(nodes);
    for (std::size_t i = 0; i < nodes; ++i) {
      const std::size_t p = position_[i];
      diagonal_[i] = {static_cast<int>(p * B), rank_in(p, p) * B, false};
    }
    off_diagonal_.resize(pairs.size());
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const std::size_t a = position_[pairs[k].first], b = position_[pairs[k].second];
      const std::size_t br = std::min(a, b), bc = std::max(a, b);
      // Block (i, j) is stored as is when i's position is above j's, transposed otherwise.
      off_diagonal_[k] = {static_cast<int>(bc * B), rank_in(br, bc) * B, a > b};
    }
    diagonal_values_.resize(n);
    rhs_.resize(n);
    if (n > 0) analyze(backend, rows);
  }

  [[nodiscard]] std::size_t nodes() const { return nodes_; }

  /// Sets every stored value and the right-hand side to zero.
  void set_zero() {
    std::fill_n(matrix_.valuePtr(), matrix_.nonZeros(), Scalar(0));
    rhs_.setZero();
  }

  /// Adds m to the diagonal block of node i (only its upper triangle is read).
  template <class Derived>
  void add_diagonal(std::size_t i, const Eigen::MatrixBase<Derived>& m) {
    const Slot& s = diagonal_[i];
    Scalar* values = matrix_.valuePtr();
    const int* starts = matrix_.outerIndexPtr();
    for (int c = 0; c < B; ++c) {
      Scalar* column = values + starts[s.column + c] + s.offset;
      for (int r = 0; r <= c; ++r)
        column[r] += m(r, c);
    }
  }

  /// Adds m to the block (pairs[k].first, pairs[k].second) of the symmetric matrix.
  template <class Derived>
  void add_off_diagonal(std::size_t k, const Eigen::MatrixBase<Derived>& m) {
    const Slot& s = off_diagonal_[k];
    Scalar* values = matrix_.valuePtr();
    const int* starts = matrix_.outerIndexPtr();
    for (int c = 0; c < B; ++c) {
      Scalar* column = values + starts[s.column + c] + s.offset;
      if (s.transposed)
        for (int r = 0; r < B; ++r)
          column[r] += m(c, r);
      else
        for (int r = 0; r < B; ++r)
          column[r] += m(r, c);
    }
  }

  /// The right-hand side segment of node i.
  [[nodiscard]] auto rhs(std::size_t i) {
    return rhs_.template segment<B>(static_cast<Eigen::Index>(position_[i] * B));
  }

  /// Remembers the current diagonal, so that damp() can be applied repeatedly.
  void save_diagonal() {
    for (std::size_t i = 0; i < nodes_; ++i)
      for (int c = 0; c < B; ++c)
        diagonal_values_(static_cast<Eigen::Index>(position_[i] * B) + c) = *diagonal_entry(i, c);
  }

  /// Sets the diagonal to d + λ·clamp(d, floor, ∞) from the saved diagonal d (Marquardt's
  /// scaling, as Ceres' LM; `floor` keeps a zero diagonal entry damped).
  void damp(Scalar lambda, Scalar floor) {
    floor_ = floor;
    for (std::size_t i = 0; i < nodes_; ++i)
      for (int c = 0; c < B; ++c) {
        const Scalar d = diagonal_values_(static_cast<Eigen::Index>(position_[i] * B) + c);
        *diagonal_entry(i, c) = d + lambda * std::max(d, floor);
      }
  }

  /// rhsᵀx for x in node order.
  [[nodiscard]] Scalar rhs_dot(const Vector& x) const {
    Scalar sum = 0;
    for (std::size_t i = 0; i < nodes_; ++i)
      sum += rhs_.template segment<B>(static_cast<Eigen::Index>(position_[i] * B))
                 .dot(x.template segment<B>(static_cast<Eigen::Index>(i * B)));
    return sum;
  }

  /// xᵀ·diag(clamp(d, floor, ∞))·x with the saved diagonal d and the floor of the last damp(),
  /// x in node order.
  [[nodiscard]] Scalar damping_norm(const Vector& x) const {
    Scalar sum = 0;
    for (std::size_t i = 0; i < nodes_; ++i) {
      const auto d =
          diagonal_values_.template segment<B>(static_cast<Eigen::Index>(position_[i] * B));
      const auto xi = x.template segment<B>(static_cast<Eigen::Index>(i * B));
      sum += (d.array().max(floor_) * xi.array().square()).sum();
    }
    return sum;
  }

  /// Numeric factorisation; false when it fails (not positive definite to working precision).
  bool factorize() {
#ifdef RANGENAV_HAVE_CHOLMOD
    if constexpr (std::is_same_v<Scalar, double>) {
      if (use_cholmod_) {
        cholmod_->factorize(matrix_);
        return cholmod_->info() == Eigen::Success;  // fails unless positive definite
      }
    }
#endif
    eigen_->factorize(matrix_);
    if (eigen_->info() != Eigen::Success) return false;
    // LDLT also "succeeds" on an indefinite matrix: require D > 0.
    return (eigen_->vectorD().array() > Scalar(0)).all();
  }

  /// True when CHOLMOD factors this pattern.
  [[nodiscard]] bool uses_cholmod() const {
    return use_cholmod_;
  }

  /// Solves for the current right-hand side; x is in the order of the nodes (x(i) = segment i).
  void solve(Vector& x) {
    solve_into(rhs_, solution_);
    x.resize(static_cast<Eigen::Index>(nodes_ * B));
    for (std::size_t i = 0; i < nodes_; ++i)
      x.template segment<B>(static_cast<Eigen::Index>(i * B)) =
          solution_.template segment<B>(static_cast<Eigen::Index>(position_[i] * B));
  }

  /// Solves for several right-hand sides at once: columns of `rhs` in node order.
  void solve(const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& rhs,
             Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& x) {
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> permuted(rhs.rows(), rhs.cols());
    for (std::size_t i = 0; i < nodes_; ++i)
      permuted.template middleRows<B>(static_cast<Eigen::Index>(position_[i] * B)) =
          rhs.template middleRows<B>(static_cast<Eigen::Index>(i * B));
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> solved;
    solve_into(permuted, solved);
    x.resize(rhs.rows(), rhs.cols());
    for (std::size_t i = 0; i < nodes_; ++i)
      x.template middleRows<B>(static_cast<Eigen::Index>(i * B)) =
          solved.template middleRows<B>(static_cast<Eigen::Index>(position_[i] * B));
  }

 private:
  struct Slot {
    int column;  // first scalar column of the block column
    int offset;  // position of the block's first row within each of its columns
    bool transposed;
  };

  // Symbolic analysis by the chosen backend (see the file comment). `rows` lists the block rows
  // of each block column of the upper triangle.
  void analyze(SparseBackend backend, const std::vector<std::vector<std::size_t>>& rows) {
    use_cholmod_ = false;
#ifdef RANGENAV_HAVE_CHOLMOD
    if constexpr (std::is_same_v<Scalar, double>) {
      if (backend == SparseBackend::cholmod ||
          (backend == SparseBackend::automatic && supernodal_pays(rows))) {
        use_cholmod_ = true;
        cholmod_ = std::make_unique<Cholmod>();
        cholmod_->setMode(Eigen::CholmodSupernodalLLt);
        cholmod_->analyzePattern(matrix_);
        return;
      }
      cholmod_.reset();
    }
#else
    (void)rows;
#endif
    (void)backend;
    eigen_ = std::make_unique<EigenSolver>();
    eigen_->analyzePattern(matrix_);
  }

#ifdef RANGENAV_HAVE_CHOLMOD
  // CHOLMOD's test for a supernodal factorisation, flops ≥ supernodal_switch·nnz(L), applied to
  // the block graph in the stored order: its symbolic analysis (elimination tree and column
  // counts, no ordering) is B² times smaller than the scalar one, and scalar L has about B²
  // entries and B³ flops per block entry and block flop.
  static bool supernodal_pays(const std::vector<std::vector<std::size_t>>& rows) {
    const auto n = static_cast<Eigen::Index>(rows.size());
    Eigen::SparseMatrix<double, Eigen::ColMajor, int> blocks(n, n);
    std::vector<int> sizes(rows.size());
    for (std::size_t c = 0; c < rows.size(); ++c)
      sizes[c] = static_cast<int>(rows[c].size());
    blocks.reserve(sizes);
    for (std::size_t c = 0; c < rows.size(); ++c)
      for (const std::size_t r : rows[c])
        blocks.insert(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = 1.0;
    blocks.makeCompressed();
    Cholmod symbolic;
    symbolic.cholmod().nmethods = 1;
    symbolic.cholmod().method[0].ordering = CHOLMOD_NATURAL;
    symbolic.cholmod().postorder = 0;
    symbolic.setMode(Eigen::CholmodSimplicialLLt);
    symbolic.analyzePattern(blocks);
    const auto& common = symbolic.cholmod();
    return double(B) * common.fl >= common.supernodal_switch * common.lnz;
  }
#endif

  template <class Rhs, class Out>
  void solve_into(const Rhs& rhs, Out& out) const {
#ifdef RANGENAV_HAVE_CHOLMOD
    if constexpr (std::is_same_v<Scalar, double>) {
      if (use_cholmod_) {
        out = cholmod_->solve(rhs);
        return;
      }
    }
#endif
    out = eigen_->solve(rhs);
  }

  Scalar* diagonal_entry(std::size_t i, int c) {
    const Slot& s = diagonal_[i];
    return matrix_.valuePtr() + matrix_.outerIndexPtr()[s.column + c] + s.offset + c;
  }

  std::size_t nodes_{0};
  std::vector<std::size_t> position_;  // node → block position in the factored order
  std::vector<Slot> diagonal_;
  std::vector<Slot> off_diagonal_;
  SparseMatrix matrix_;
  Vector diagonal_values_;
  Scalar floor_{0};
  Vector rhs_;
  Vector solution_;
  // Held by pointer: Eigen's solvers can be neither copied nor moved.
  using EigenSolver =
      Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>>;
  std::unique_ptr<EigenSolver> eigen_;
#ifdef RANGENAV_HAVE_CHOLMOD
  using Cholmod = typename CholmodFor<Scalar>::type;
  std::unique_ptr<Cholmod> cholmod_;
#endif
  bool use_cholmod_{false};
};

}  // namespace rangenav::detail
