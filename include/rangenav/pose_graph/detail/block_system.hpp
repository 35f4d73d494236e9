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

#include <Eigen/Core>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace rangenav::detail {

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
        rhs_(other.rhs_) {
    if (matrix_.rows() > 0) solver_->analyzePattern(matrix_);
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
  /// indices, i ≠ j; repeated pairs share one block). Afterwards off_diagonal_slot(k) names the
  /// block of pairs[k].
  void build(std::size_t nodes, const std::vector<std::pair<std::size_t, std::size_t>>& pairs) {
    nodes_ = nodes;
    // AMD on the block graph (lower triangle of the node adjacency; Eigen symmetrises it).
    std::vector<Eigen::Triplet<Scalar, int>> entries;
    entries.reserve(pairs.size() + nodes);
    for (std::size_t i = 0; i < nodes; ++i)
      entries.emplace_back(static_cast<int>(i), static_cast<int>(i), Scalar(1));
    for (const auto& [i, j] : pairs)
      entries.emplace_back(static_cast<int>(std::max(i, j)), static_cast<int>(std::min(i, j)),
                           Scalar(1));
    position_.resize(nodes);
    if (nodes > 0) {
      SparseMatrix graph(static_cast<Eigen::Index>(nodes), static_cast<Eigen::Index>(nodes));
      graph.setFromTriplets(entries.begin(), entries.end());
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
      Eigen::AMDOrdering<int> amd;
      amd(graph, order);  // order.indices()[new] = old
      for (std::size_t k = 0; k < nodes; ++k)
        position_[static_cast<std::size_t>(order.indices()[static_cast<Eigen::Index>(k)])] = k;
    }

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
    if (!solver_) solver_ = std::make_unique<Solver>();  // moved from
    if (n > 0) solver_->analyzePattern(matrix_);
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
    solver_->factorize(matrix_);
    if (solver_->info() != Eigen::Success) return false;
    // LDLT also "succeeds" on an indefinite matrix: require D > 0.
    return (solver_->vectorD().array() > Scalar(0)).all();
  }

  /// Solves for the current right-hand side; x is in the order of the nodes (x(i) = segment i).
  void solve(Vector& x) {
    solution_ = solver_->solve(rhs_);
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
    const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> solved = solver_->solve(permuted);
    x.resize(rhs.rows(), rhs.cols());
    for (std::size_t i = 0; i < nodes_; ++i)
      x.template middleRows<B>(static_cast<Eigen::Index>(i * B)) =
          solved.template middleRows<B>(static_cast<Eigen::Index>(position_[i] * B));
  }

  /// Number of stored entries of the factor L (a measure of fill-in).
  [[nodiscard]] Eigen::Index factor_non_zeros() const {
    return solver_->matrixL().nestedExpression().nonZeros();
  }

 private:
  struct Slot {
    int column;  // first scalar column of the block column
    int offset;  // position of the block's first row within each of its columns
    bool transposed;
  };

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
  using Solver = Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>>;
  // Held by pointer: Eigen's solvers can be neither copied nor moved.
  std::unique_ptr<Solver> solver_ = std::make_unique<Solver>();
};

}  // namespace rangenav::detail
