#include "swerve/solvers/ipopt_solver.hpp"

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/ocp/condensed_gauss_newton.hpp"
#include "swerve/ocp/ocp_derivatives.hpp"
#include "swerve/ocp/stage_quasi_newton.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {
namespace {

// Where the Hessian of the Lagrangian comes from (IpoptOptions::hessian).
enum class IpoptHessian { kExact, kStageQuasiNewton, kLimitedMemory };

constexpr double kIpoptInfinity = 1e20;  // beyond Ipopt's nlp_{lower,upper}_bound_inf (1e19)
constexpr double kNoCpuTimeLimit = 1e9;  // s: no limit of Ipopt's own

double clamp_to_ipopt(double bound) { return std::clamp(bound, -kIpoptInfinity, kIpoptInfinity); }

}  // namespace

// Writes a sparse structure's (row, column) pairs into Ipopt's triplet arrays, in order.
struct TripletWriter {
  Ipopt::Index* rows;
  Ipopt::Index* columns;
  int next = 0;
  void operator()(int row, int column) {
    rows[next] = row;
    columns[next] = column;
    ++next;
  }
};

// The multiple-shooting NLP. Variables are stored stage by stage, [u_k (nu), x_{k+1} (nx)] for
// k = 0..N-1, so the constraint Jacobian is block banded, and so is the Hessian of the Lagrangian:
// stage k's terms (tracking at x_{k+1}; effort, rate, wear and dynamics at x_k, u_k) touch only
// its own block and u_k's rows against the block before.
class MultipleShootingNlp final : public Ipopt::TNLP {
 public:
  MultipleShootingNlp(const OcpProblem& shape, IpoptHessian hessian)
      : horizon_(shape.horizon()), nx_(shape.state_size()), nu_(shape.input_size()), block_(nu_ + nx_),
        hessian_kind_(hessian), exact_hessian_(hessian != IpoptHessian::kLimitedMemory), derivatives_(shape) {
    for (int i = 0; i < nu_; ++i) {
      if (std::isfinite(shape.bounds().max_step[i])) rate_inputs_.push_back(i);
    }
    rate_count_ = static_cast<int>(rate_inputs_.size());
    next_states_ = Eigen::MatrixXd::Zero(nx_, horizon_);
    d_x_next_ = Eigen::VectorXd::Zero(nx_);
    d_u_ = Eigen::VectorXd::Zero(nu_);
    d_u_before_ = Eigen::VectorXd::Zero(nu_);
    start_ = Eigen::VectorXd::Zero(variables());
    final_ = Eigen::VectorXd::Zero(variables());
    lambda_ = Eigen::VectorXd::Zero(constraints());
    constraints_ = Eigen::VectorXd::Zero(constraints());
    z_lower_ = Eigen::VectorXd::Zero(variables());
    z_upper_ = Eigen::VectorXd::Zero(variables());
    if (hessian_kind_ == IpoptHessian::kStageQuasiNewton) {
      quasi_newton_ = std::make_unique<StageQuasiNewton>(shape);
      stage_points_ = Eigen::MatrixXd::Zero(nx_ + nu_, horizon_);
      stage_costates_ = Eigen::MatrixXd::Zero(nx_, horizon_);
    }
    if (exact_hessian_) {
      if (hessian_kind_ == IpoptHessian::kExact) probe_ = std::make_unique<OcpDerivatives>(shape);
      hessian_blocks_.assign(static_cast<std::size_t>(horizon_), Eigen::MatrixXd::Zero(block_, block_));
      hessian_couplings_.assign(static_cast<std::size_t>(horizon_), Eigen::MatrixXd::Zero(nu_, nx_));
      const int nz = nx_ + nu_;
      point_ = Eigen::VectorXd::Zero(nz);
      probe_next_ = Eigen::VectorXd::Zero(nx_);
      gradient_ = gradient_step_ = Eigen::VectorXd::Zero(nz);
      stage_hessian_ = Eigen::MatrixXd::Zero(nz, nz);
      tracked_ = tracked_step_ = Eigen::VectorXd::Zero(nx_);
      tracking_hessian_ = Eigen::MatrixXd::Zero(OcpProblem::kTrackedStates, OcpProblem::kTrackedStates);
    }
  }

  int variables() const { return horizon_ * block_; }
  int constraints() const { return horizon_ * (nx_ + rate_count_); }

  // Per solve: the problem, the start point (inputs nu x N and their rollout states nx x N+1).
  void prepare(const OcpProblem& problem, PredictionData& data, const Eigen::MatrixXd& inputs,
               const Eigen::MatrixXd& states, Deadline deadline, bool warm_multipliers, Duration iteration_estimate) {
    problem_ = &problem;
    data_ = &data;
    deadline_ = deadline;
    iteration_estimate_ = iteration_estimate;
    for (int k = 0; k < horizon_; ++k) {
      start_.segment(k * block_, nu_) = inputs.col(k);
      start_.segment(k * block_ + nu_, nx_) = states.col(k + 1);
    }
    use_warm_multipliers_ = warm_multipliers;
    if (quasi_newton_ != nullptr) quasi_newton_->begin_solve();
    have_final_ = false;
    iterations_ = 0;
    evaluations_ = 0;
    last_iteration_ = deadline.now();
    first_callback_ = TimePoint{};
    longest_iteration_ = longest_step_ = abandoned_iteration_ = hessian_time_ = Duration::zero();
  }

  // The final iterate's inputs (nu x N) and its largest dynamics defect.
  bool final_inputs(Eigen::MatrixXd* inputs, double* max_defect) {
    if (!have_final_) return false;
    for (int k = 0; k < horizon_; ++k) inputs->col(k) = final_.segment(k * block_, nu_);
    *max_defect = defect_of(final_.data());
    return inputs->allFinite();
  }

  // Shifts the stored multipliers by one step for the next cycle (the last stage's repeat).
  void shift_multipliers() {
    for (int k = 0; k + 1 < horizon_; ++k) {
      lambda_.segment(k * nx_, nx_) = lambda_.segment((k + 1) * nx_, nx_);
      z_lower_.segment(k * block_, block_) = z_lower_.segment((k + 1) * block_, block_);
      z_upper_.segment(k * block_, block_) = z_upper_.segment((k + 1) * block_, block_);
      if (rate_count_ > 0) {
        lambda_.segment(horizon_ * nx_ + k * rate_count_, rate_count_) =
            lambda_.segment(horizon_ * nx_ + (k + 1) * rate_count_, rate_count_);
      }
    }
  }

  bool has_final() const { return have_final_; }
  // When iteration 0 (Ipopt's initialisation: first evaluations and factorisation) ended.
  TimePoint first_callback() const { return first_callback_; }
  // Non-zero when the last solve abandoned a Hessian at the deadline: the iteration it foresaw.
  Duration abandoned_iteration() const { return abandoned_iteration_; }
  // The longest iteration of the last solve after its first iterate (zero if it made none).
  Duration longest_step() const { return longest_step_; }
  int iterations() const { return iterations_; }
  long evaluations() const { return evaluations_; }
  Ipopt::SolverReturn final_status() const { return final_status_; }

  // --- Ipopt::TNLP ---
  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = variables();
    m = constraints();
    // Per stage: identity on x_{k+1}, -B_k on u_k, -A_k on x_k (k >= 1); rate rows +1 / -1.
    nnz_jac_g = horizon_ * (nx_ + nx_ * nu_) + (horizon_ - 1) * nx_ * nx_ + rate_count_ * (2 * horizon_ - 1);
    nnz_h_lag = exact_hessian_ ? hessian_entries() : 0;  // 0: limited-memory quasi-Newton
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index m, Ipopt::Number* g_l,
                       Ipopt::Number* g_u) override {
    (void)n;
    (void)m;
    const InputBounds& bounds = problem_->bounds();
    for (int k = 0; k < horizon_; ++k) {
      for (int i = 0; i < nu_; ++i) {
        x_l[k * block_ + i] = clamp_to_ipopt(bounds.lower[i]);
        x_u[k * block_ + i] = clamp_to_ipopt(bounds.upper[i]);
      }
      for (int j = 0; j < nx_; ++j) {
        x_l[k * block_ + nu_ + j] = -kIpoptInfinity;
        x_u[k * block_ + nu_ + j] = kIpoptInfinity;
      }
    }
    for (int r = 0; r < horizon_ * nx_; ++r) g_l[r] = g_u[r] = 0.0;
    for (int k = 0; k < horizon_; ++k) {
      for (int c = 0; c < rate_count_; ++c) {
        const int i = rate_inputs_[static_cast<std::size_t>(c)];
        const int row = horizon_ * nx_ + k * rate_count_ + c;
        const double max_step = bounds.max_step[i];
        // Row k = 0 is u_0 itself (u_{-1} is a constant); later rows are u_k - u_{k-1}.
        const double centre = k == 0 ? problem_->previous_input()[i] : 0.0;
        g_l[row] = centre - max_step;
        g_u[row] = centre + max_step;
      }
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool init_z, Ipopt::Number* z_L,
                          Ipopt::Number* z_U, Ipopt::Index m, bool init_lambda, Ipopt::Number* lambda) override {
    if (init_x) std::copy(start_.data(), start_.data() + n, x);
    if (init_z) {
      if (!use_warm_multipliers_) return false;
      std::copy(z_lower_.data(), z_lower_.data() + n, z_L);
      std::copy(z_upper_.data(), z_upper_.data() + n, z_U);
    }
    if (init_lambda) {
      if (!use_warm_multipliers_) return false;
      std::copy(lambda_.data(), lambda_.data() + m, lambda);
    }
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number& obj_value) override {
    (void)n;
    if (new_x || !values_ready_) evaluate_values(x);
    if (!values_ok_) return false;
    obj_value = objective_;
    return true;
  }

  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number* grad_f) override {
    if (new_x || !derivatives_ready_) evaluate_derivatives(x);
    if (!derivatives_ok_) return false;
    std::fill(grad_f, grad_f + n, 0.0);
    const double lambda = problem_->weights().wear;
    for (int k = 0; k < horizon_; ++k) {
      problem_->stage_cost_without_wear(k, state_after(x, k), input(x, k), input_before(x, k), d_x_next_, d_u_,
                                        d_u_before_);
      Eigen::Map<Eigen::VectorXd>(grad_f + k * block_, nu_) += d_u_ + lambda * derivatives_.wear_gradient(k).tail(nu_);
      Eigen::Map<Eigen::VectorXd>(grad_f + k * block_ + nu_, nx_) += d_x_next_;
      if (k > 0) {
        Eigen::Map<Eigen::VectorXd>(grad_f + (k - 1) * block_, nu_) += d_u_before_;
        Eigen::Map<Eigen::VectorXd>(grad_f + (k - 1) * block_ + nu_, nx_) +=
            lambda * derivatives_.wear_gradient(k).head(nx_);
      }
    }
    return true;
  }

  bool eval_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m, Ipopt::Number* g) override {
    (void)n;
    (void)m;
    if (new_x || !values_ready_) evaluate_values(x);
    if (!values_ok_) return false;
    write_constraints(x, g);
    return true;
  }

  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m, Ipopt::Index nele_jac,
                  Ipopt::Index* i_row, Ipopt::Index* j_col, Ipopt::Number* values) override {
    (void)n;
    (void)m;
    (void)nele_jac;
    if (values == nullptr) {
      write_structure(i_row, j_col);
      return true;
    }
    if (new_x || !derivatives_ready_) evaluate_derivatives(x);
    if (!derivatives_ok_) return false;
    int e = 0;
    for (int k = 0; k < horizon_; ++k) {
      for (int i = 0; i < nx_; ++i) values[e++] = 1.0;
      const Eigen::MatrixXd& b = derivatives_.b(k);
      for (int i = 0; i < nx_; ++i) {
        for (int j = 0; j < nu_; ++j) values[e++] = -b(i, j);
      }
      if (k > 0) {
        const Eigen::MatrixXd& a = derivatives_.a(k);
        for (int i = 0; i < nx_; ++i) {
          for (int j = 0; j < nx_; ++j) values[e++] = -a(i, j);
        }
      }
    }
    for (int k = 0; k < horizon_; ++k) {
      for (int c = 0; c < rate_count_; ++c) {
        values[e++] = 1.0;
        if (k > 0) values[e++] = -1.0;
      }
    }
    return true;
  }

  // The Hessian of obj_factor * f + multipliers^T g, per stage k (z_k = [x_k; u_k]):
  //   tracking:       d2/dx_{k+1}^2 of the stage's tracking cost (forward differences of its exact
  //                   gradient; it costs no model step),
  //   effort, rate:   their constant weights (1/2 r^2 with r linear in the inputs),
  //   wear, dynamics: d2/dz_k^2 of obj_factor lambda W_k(z_k) - mu_k^T F(z_k), forward differences of
  //                   the Jet gradients (A_k, B_k, dW_k) that linearize_stage gives;
  // the rate rows are linear. Forward differences with a relative step of 1e-6 (Nocedal & Wright,
  // 2nd ed., 8.1: the gradient's error over h plus h times the third derivative).
  bool eval_h(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Number obj_factor, Ipopt::Index m,
              const Ipopt::Number* multipliers, bool new_lambda, Ipopt::Index nele_hess, Ipopt::Index* i_row,
              Ipopt::Index* j_col, Ipopt::Number* values) override {
    (void)n, (void)m, (void)new_lambda, (void)nele_hess;
    if (!exact_hessian_) return false;
    if (values == nullptr) {
      write_hessian_structure(i_row, j_col);
      return true;
    }
    // The columns difference against the iterate's own linearisation (eval_jac_g's).
    if (new_x || !derivatives_ready_) evaluate_derivatives(x);
    if (!derivatives_ok_ || !lagrangian_hessian(x, obj_factor, multipliers)) return false;
    int e = 0;
    for (int k = 0; k < horizon_; ++k) {
      const std::size_t stage = static_cast<std::size_t>(k);
      if (k > 0) {
        // u_k against [u_{k-1}, x_k]: the rate term's -S, then the wear's and dynamics' cross terms.
        for (int i = 0; i < nu_; ++i) {
          const double rate_weight = problem_->rate_root()[i] * problem_->rate_root()[i];
          for (int j = 0; j < nu_; ++j) values[e++] = i == j ? -obj_factor * rate_weight : 0.0;
          for (int j = 0; j < nx_; ++j) values[e++] = hessian_couplings_[stage](i, j);
        }
      }
      const Eigen::MatrixXd& diagonal = hessian_blocks_[stage];
      for (int i = 0; i < block_; ++i) {
        for (int j = 0; j <= i; ++j) values[e++] = diagonal(i, j);
      }
    }
    return true;
  }

  bool intermediate_callback(Ipopt::AlgorithmMode mode, Ipopt::Index iter, Ipopt::Number obj_value,
                             Ipopt::Number inf_pr, Ipopt::Number inf_du, Ipopt::Number mu, Ipopt::Number d_norm,
                             Ipopt::Number regularization_size, Ipopt::Number alpha_du, Ipopt::Number alpha_pr,
                             Ipopt::Index ls_trials, const Ipopt::IpoptData* ip_data,
                             Ipopt::IpoptCalculatedQuantities* ip_cq) override {
    (void)mode, (void)obj_value, (void)inf_pr, (void)inf_du, (void)mu, (void)d_norm, (void)regularization_size;
    (void)alpha_du, (void)alpha_pr, (void)ls_trials, (void)ip_data, (void)ip_cq;
    iterations_ = iter;
    const TimePoint now = deadline_.now();
    if (iter == 0) first_callback_ = now;
    longest_iteration_ = std::max(longest_iteration_, now - last_iteration_);
    if (iter > 0) {
      longest_step_ = std::max(longest_step_, now - last_iteration_);
      if (hessian_time_ > Duration::zero()) {
        // The iteration's work besides its Hessian (factorisation, line search, next Jacobians).
        rest_estimate_ = updated_estimate(rest_estimate_, std::max(Duration::zero(), now - last_iteration_ - hessian_time_));
      }
    }
    hessian_time_ = Duration::zero();
    last_iteration_ = now;
    // Stop when one more iteration and the final rollout would not fit. The next iteration is
    // foreseen as the longest so far, and at least as the past solves' iterations: the time to the
    // first iterate holds no Hessian, so alone it underestimated an exact-Hessian iteration ~20x
    // (10 modules with lags: 3 ms to the first iterate, 70 ms per iteration).
    const Duration next = std::max(longest_iteration_, iteration_estimate_);
    return now + next + next / 4 < deadline_.at();
  }

  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n, const Ipopt::Number* x, const Ipopt::Number* z_L,
                         const Ipopt::Number* z_U, Ipopt::Index m, const Ipopt::Number* g, const Ipopt::Number* lambda,
                         Ipopt::Number obj_value, const Ipopt::IpoptData* ip_data,
                         Ipopt::IpoptCalculatedQuantities* ip_cq) override {
    (void)g, (void)obj_value, (void)ip_data, (void)ip_cq;
    final_status_ = status;
    if (x == nullptr) return;
    std::copy(x, x + n, final_.data());
    have_final_ = final_.allFinite();
    if (z_L != nullptr && z_U != nullptr && lambda != nullptr) {
      std::copy(z_L, z_L + n, z_lower_.data());
      std::copy(z_U, z_U + n, z_upper_.data());
      std::copy(lambda, lambda + m, lambda_.data());
    }
  }

 private:
  Eigen::Map<const Eigen::VectorXd> input(const Ipopt::Number* x, int k) const {
    return Eigen::Map<const Eigen::VectorXd>(x + k * block_, nu_);
  }
  Eigen::Map<const Eigen::VectorXd> input_before(const Ipopt::Number* x, int k) const {
    return k == 0 ? Eigen::Map<const Eigen::VectorXd>(problem_->previous_input().data(), nu_) : input(x, k - 1);
  }
  // x_{k+1}
  Eigen::Map<const Eigen::VectorXd> state_after(const Ipopt::Number* x, int k) const {
    return Eigen::Map<const Eigen::VectorXd>(x + k * block_ + nu_, nx_);
  }
  // x_k (the measured state for k = 0)
  Eigen::Map<const Eigen::VectorXd> state_at(const Ipopt::Number* x, int k) const {
    return k == 0 ? Eigen::Map<const Eigen::VectorXd>(problem_->initial_state().data(), nx_) : state_after(x, k - 1);
  }

  void evaluate_values(const Ipopt::Number* x) {
    ++evaluations_;
    derivatives_ready_ = false;
    values_ready_ = true;
    values_ok_ = true;
    objective_ = 0.0;
    const double lambda = problem_->weights().wear;
    for (int k = 0; k < horizon_ && values_ok_; ++k) {
      double wear = 0.0;
      values_ok_ = problem_->model().step(*data_, state_at(x, k), input(x, k), problem_->dt(), next_states_.col(k), &wear) &&
                   std::isfinite(wear);
      objective_ += problem_->stage_cost_without_wear(k, state_after(x, k), input(x, k), input_before(x, k), d_x_next_,
                                                      d_u_, d_u_before_) +
                    lambda * wear;
    }
    values_ok_ = values_ok_ && std::isfinite(objective_);
  }

  void evaluate_derivatives(const Ipopt::Number* x) {
    if (!values_ready_) evaluate_values(x);
    derivatives_ready_ = true;
    derivatives_ok_ = values_ok_;
    for (int k = 0; k < horizon_ && derivatives_ok_; ++k) {
      derivatives_ok_ = derivatives_.linearize_stage(*problem_, k, state_at(x, k), input(x, k), next_states_.col(k));
    }
  }

  // Dynamics defects (the heading's wrapped: a state variable may sit a turn away from F's) and
  // the rate rows.
  void write_constraints(const Ipopt::Number* x, Ipopt::Number* g) const {
    for (int k = 0; k < horizon_; ++k) {
      Eigen::Map<Eigen::VectorXd> defect(g + k * nx_, nx_);
      defect = state_after(x, k) - next_states_.col(k);
      defect[StateIndex::kPsi] = wrap_angle(defect[StateIndex::kPsi]);
    }
    for (int k = 0; k < horizon_; ++k) {
      for (int c = 0; c < rate_count_; ++c) {
        const int i = rate_inputs_[static_cast<std::size_t>(c)];
        g[horizon_ * nx_ + k * rate_count_ + c] = x[k * block_ + i] - (k == 0 ? 0.0 : x[(k - 1) * block_ + i]);
      }
    }
  }

  // The largest dynamics defect at x (the rows write_constraints gives Ipopt).
  double defect_of(const Ipopt::Number* x) {
    evaluate_values(x);
    if (!values_ok_) return std::numeric_limits<double>::infinity();
    write_constraints(x, constraints_.data());
    return constraints_.head(horizon_ * nx_).cwiseAbs().maxCoeff();
  }

  void write_structure(Ipopt::Index* i_row, Ipopt::Index* j_col) const {
    TripletWriter add{i_row, j_col};
    for (int k = 0; k < horizon_; ++k) {
      const int row = k * nx_;
      for (int i = 0; i < nx_; ++i) add(row + i, k * block_ + nu_ + i);
      for (int i = 0; i < nx_; ++i) {
        for (int j = 0; j < nu_; ++j) add(row + i, k * block_ + j);
      }
      if (k > 0) {
        for (int i = 0; i < nx_; ++i) {
          for (int j = 0; j < nx_; ++j) add(row + i, (k - 1) * block_ + nu_ + j);
        }
      }
    }
    for (int k = 0; k < horizon_; ++k) {
      for (int c = 0; c < rate_count_; ++c) {
        const int i = rate_inputs_[static_cast<std::size_t>(c)];
        const int row = horizon_ * nx_ + k * rate_count_ + c;
        add(row, k * block_ + i);
        if (k > 0) add(row, (k - 1) * block_ + i);
      }
    }
  }

  // Per stage k: the lower triangle of its block [u_k, x_{k+1}] and, for k >= 1, u_k's rows against
  // the block before, [u_{k-1}, x_k].
  int hessian_entries() const { return horizon_ * block_ * (block_ + 1) / 2 + (horizon_ - 1) * nu_ * block_; }

  void write_hessian_structure(Ipopt::Index* i_row, Ipopt::Index* j_col) const {
    TripletWriter add{i_row, j_col};
    for (int k = 0; k < horizon_; ++k) {
      if (k > 0) {
        for (int i = 0; i < nu_; ++i) {
          for (int j = 0; j < block_; ++j) add(k * block_ + i, (k - 1) * block_ + j);
        }
      }
      for (int i = 0; i < block_; ++i) {
        for (int j = 0; j <= i; ++j) add(k * block_ + i, k * block_ + j);
      }
    }
  }

  // Forward-difference step for a coordinate of value v.
  static double difference_step(double v) { return 1e-6 * std::max(1.0, std::abs(v)); }

  // obj_factor lambda dW_k - [A_k B_k]^T mu_k from stage k's linearisation in `linearised`.
  bool stage_lagrangian_gradient(const OcpDerivatives& linearised, int k, double obj_factor,
                                 const Ipopt::Number* multipliers, Eigen::VectorXd* gradient) const {
    const Eigen::Map<const Eigen::VectorXd> mu(multipliers + k * nx_, nx_);
    const double wear_factor = obj_factor * problem_->weights().wear;
    gradient->head(nx_).noalias() = wear_factor * linearised.wear_gradient(k).head(nx_) - linearised.a(k).transpose() * mu;
    gradient->tail(nu_).noalias() = wear_factor * linearised.wear_gradient(k).tail(nu_) - linearised.b(k).transpose() * mu;
    return gradient->allFinite();
  }

  // Fills hessian_blocks_ (lower triangles used) and hessian_couplings_ (u_k against x_k) at x,
  // whose linearisation derivatives_ holds. false when the model fails at a perturbed point.
  bool lagrangian_hessian(const Ipopt::Number* x, double obj_factor, const Ipopt::Number* multipliers) {
    const TimePoint started = deadline_.now();
    const int nz = nx_ + nu_;
    const int tracked = OcpProblem::kTrackedStates;
    for (int k = 0; k < horizon_; ++k) {
      const std::size_t stage = static_cast<std::size_t>(k);
      Eigen::MatrixXd& diagonal = hessian_blocks_[stage];
      diagonal.setZero();
      // Tracking at x_{k+1}: columns of d/dx_{k+1} of its gradient (the inputs do not enter it).
      point_.head(nx_) = state_after(x, k);
      problem_->stage_cost_without_wear(k, point_.head(nx_), input(x, k), input_before(x, k), tracked_, d_u_,
                                        d_u_before_);
      for (int j = 0; j < tracked; ++j) {
        const double h = difference_step(point_[j]);
        point_[j] += h;
        problem_->stage_cost_without_wear(k, point_.head(nx_), input(x, k), input_before(x, k), tracked_step_, d_u_,
                                          d_u_before_);
        point_[j] = state_after(x, k)[j];
        tracking_hessian_.col(j) = (tracked_step_.head(tracked) - tracked_.head(tracked)) / h;
      }
      diagonal.block(nu_, nu_, tracked, tracked) =
          0.5 * obj_factor * (tracking_hessian_ + tracking_hessian_.transpose());
      // The state effort 1/2 |x_{k+1}|^2_W: W on its states' diagonal.
      for (Eigen::Index j = 0; j < problem_->state_effort_index().size(); ++j) {
        const int state = problem_->state_effort_index()[j];
        const double root = problem_->state_effort_root()[j];
        diagonal(nu_ + state, nu_ + state) += obj_factor * root * root;
      }
      // Effort and rate: R + S on u_k, and S again from stage k + 1's rate term.
      for (int i = 0; i < nu_; ++i) {
        const double rate_weight = problem_->rate_root()[i] * problem_->rate_root()[i];
        const double effort_weight = problem_->effort_root()[i] * problem_->effort_root()[i];
        diagonal(i, i) += obj_factor * (effort_weight + rate_weight + (k + 1 < horizon_ ? rate_weight : 0.0));
      }
    }
    if (hessian_kind_ == IpoptHessian::kStageQuasiNewton) {
      learnt_stage_blocks(x, obj_factor, multipliers);
      hessian_time_ += deadline_.now() - started;
      return true;
    }
    for (int k = 0; k < horizon_; ++k) {
      if (k > 0 && !hessian_fits(started, k)) return false;
      // Wear and dynamics of stage k over z_k = [x_k; u_k]; x_0 is no variable, so only u_0 there.
      const std::size_t stage = static_cast<std::size_t>(k);
      const int first = k == 0 ? nx_ : 0;
      point_.head(nx_) = state_at(x, k);
      point_.tail(nu_) = input(x, k);
      if (!stage_lagrangian_gradient(derivatives_, k, obj_factor, multipliers, &gradient_)) return false;
      for (int j = first; j < nz; ++j) {
        const double value = point_[j];
        const double h = difference_step(value);
        point_[j] = value + h;
        const bool ok = probe_->linearize_stage(*problem_, k, point_.head(nx_), point_.tail(nu_), probe_next_) &&
                        stage_lagrangian_gradient(*probe_, k, obj_factor, multipliers, &gradient_step_);
        point_[j] = value;
        if (!ok) return false;
        stage_hessian_.col(j) = (gradient_step_ - gradient_) / h;
      }
      // Symmetric part of the columns computed (u_0's block alone at k = 0).
      const auto u_u = stage_hessian_.bottomRightCorner(nu_, nu_);
      hessian_blocks_[stage].topLeftCorner(nu_, nu_) += 0.5 * (u_u + u_u.transpose());
      if (k > 0) {
        const auto x_x = stage_hessian_.topLeftCorner(nx_, nx_);
        hessian_blocks_[stage - 1].bottomRightCorner(nx_, nx_) += 0.5 * (x_x + x_x.transpose());
        hessian_couplings_[stage] =
            0.5 * (stage_hessian_.bottomLeftCorner(nu_, nx_) + stage_hessian_.topRightCorner(nx_, nu_).transpose());
      }
    }
    hessian_time_ += deadline_.now() - started;
    return true;
  }

  // The wear's and the dynamics' curvature of each stage learnt from the iterates (StageQuasiNewton:
  // damped BFGS on obj_factor lambda W - mu^T F, i.e. on lambda W + nu^T F with nu = -mu /
  // obj_factor), plus the wear's generalised Gauss-Newton term, added to the blocks at x. In
  // Ipopt's restoration phase (obj_factor 0) the blocks keep the constraint-free part only.
  void learnt_stage_blocks(const Ipopt::Number* x, double obj_factor, const Ipopt::Number* multipliers) {
    if (!(obj_factor > 0.0)) return;
    for (int k = 0; k < horizon_; ++k) {
      stage_points_.col(k).head(nx_) = state_at(x, k);
      stage_points_.col(k).tail(nu_) = input(x, k);
      stage_costates_.col(k) = -Eigen::Map<const Eigen::VectorXd>(multipliers + k * nx_, nx_) / obj_factor;
    }
    quasi_newton_->update_at(*problem_, derivatives_, stage_points_, stage_costates_, true);
    const double lambda = problem_->weights().wear;
    for (int k = 0; k < horizon_; ++k) {
      const std::size_t stage = static_cast<std::size_t>(k);
      stage_hessian_ = quasi_newton_->block(k);
      if (lambda > 0.0) {
        const Eigen::VectorXd& g = derivatives_.wear_gradient(k);
        const double weight = CondensedGaussNewton::wear_curvature_weight(lambda, derivatives_.wear(k));
        stage_hessian_.noalias() += weight * g * g.transpose();
      }
      stage_hessian_ *= obj_factor;
      hessian_blocks_[stage].topLeftCorner(nu_, nu_) += stage_hessian_.bottomRightCorner(nu_, nu_);
      if (k > 0) {
        hessian_blocks_[stage - 1].bottomRightCorner(nx_, nx_) += stage_hessian_.topLeftCorner(nx_, nx_);
        hessian_couplings_[stage] = stage_hessian_.bottomLeftCorner(nu_, nx_);
      }
    }
  }

  // Whether the rest of the Hessian, after `done` of its stages since `started`, and the rest of
  // the iteration still end before the deadline. The rest (factorisation, line search, the next
  // Jacobians) is measured in past iterations (x1.25); before the first, a whole Hessian is
  // assumed, as the solver's first iteration is its slowest (first run: 8.4 ms against 5.5). If
  // not, the Hessian is abandoned: Ipopt stops with an evaluation error, and do_solve returns the
  // last iterate on time and learns the whole iteration foreseen (abandoned_iteration()).
  bool hessian_fits(TimePoint started, int done) {
    const TimePoint now = deadline_.now();
    const Duration per_stage = (now - started) / done;
    const Duration rest = rest_estimate_ > Duration::zero() ? rest_estimate_ + rest_estimate_ / 4 : per_stage * horizon_;
    if (now + per_stage * (horizon_ - done) + rest < deadline_.at()) return true;
    abandoned_iteration_ = (started - last_iteration_) + per_stage * horizon_ + rest;
    return false;
  }

  int horizon_, nx_, nu_, block_;
  IpoptHessian hessian_kind_;
  bool exact_hessian_;  // a Hessian of Ipopt's own structure (exact or learnt), not Ipopt's L-BFGS
  int rate_count_ = 0;
  std::vector<int> rate_inputs_;
  OcpDerivatives derivatives_;
  const OcpProblem* problem_ = nullptr;
  PredictionData* data_ = nullptr;  // the model's scratch (the solver's)
  Deadline deadline_{};
  Eigen::MatrixXd next_states_;  // F(x_k, u_k), nx x N
  Eigen::VectorXd d_x_next_, d_u_, d_u_before_;
  // The exact Hessian: a second linearisation scratch (derivatives_ keeps the iterate's Jacobians
  // for eval_jac_g), per stage its diagonal block and u_k's coupling to x_k, and scratch.
  std::unique_ptr<OcpDerivatives> probe_;
  // The learnt Hessian: the stage memory, and this iterate's stage points and scaled multipliers.
  std::unique_ptr<StageQuasiNewton> quasi_newton_;
  Eigen::MatrixXd stage_points_, stage_costates_;
  std::vector<Eigen::MatrixXd> hessian_blocks_, hessian_couplings_;
  Eigen::VectorXd point_, probe_next_, gradient_, gradient_step_, tracked_, tracked_step_;
  Eigen::MatrixXd stage_hessian_, tracking_hessian_;
  double objective_ = 0.0;
  bool values_ready_ = false, values_ok_ = false, derivatives_ready_ = false, derivatives_ok_ = false;
  Eigen::VectorXd start_, final_, lambda_, z_lower_, z_upper_, constraints_;
  bool use_warm_multipliers_ = false, have_final_ = false;
  Ipopt::SolverReturn final_status_ = Ipopt::INTERNAL_ERROR;
  int iterations_ = 0;
  long evaluations_ = 0;
  TimePoint last_iteration_{}, first_callback_{};
  Duration longest_iteration_{}, longest_step_{}, iteration_estimate_{}, abandoned_iteration_{};
  // This iteration's Hessian time, and the rest of an iteration measured over past solves.
  Duration hessian_time_{}, rest_estimate_{};
};

struct IpoptSolver::Impl {
  Impl(const OcpProblem& shape, IpoptHessian hessian)
      : exact_hessian(hessian == IpoptHessian::kExact), hessian_kind(hessian),
        nlp(new MultipleShootingNlp(shape, hessian)), app(IpoptApplicationFactory()), start(shape) {
    inputs = best_inputs = Eigen::MatrixXd::Zero(shape.input_size(), shape.horizon());
    states = best_states = Eigen::MatrixXd::Zero(shape.state_size(), shape.horizon() + 1);
    stage_costs = stage_wear = best_stage_wear = Eigen::VectorXd::Zero(shape.horizon());
  }
  const bool exact_hessian;  // options.hessian == "exact", read once
  const IpoptHessian hessian_kind;
  Ipopt::SmartPtr<MultipleShootingNlp> nlp;
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app;
  bool have_multipliers = false;
  // How long Ipopt takes to reach its first iterate (initialisation, first derivatives and
  // factorisation), from past solves; before the first, a multiple of the guesses' rollout time.
  Duration startup_estimate{};
  // How long one iteration takes (the Hessian, the factorisation, the line search), from past
  // solves; never below the estimate from this solve's rollout time (see do_solve).
  Duration iteration_estimate{};
  StartPlan start;
  Eigen::MatrixXd inputs, best_inputs, states, best_states;
  Eigen::VectorXd stage_costs, stage_wear, best_stage_wear;

  // Whether Ipopt's first iterate and one iteration fit before the deadline, by the estimates of
  // past solves (before the first: multiples of this solve's rollout time). When they do not,
  // lowers the estimates (see the definition) and returns false.
  bool first_iterate_fits(const OcpProblem& problem, const Deadline& deadline) noexcept;
  // Runs Ipopt from the best guess, warm as `options` ask, and updates the estimates from its
  // callbacks; *abandoned when it stopped inside its Hessian at the deadline.
  Ipopt::ApplicationReturnStatus optimize(const OcpProblem& problem, PredictionData& data, const Deadline& deadline,
                                          const IpoptOptions& options, bool* abandoned);
};

bool IpoptSolver::Impl::first_iterate_fits(const OcpProblem& problem, const Deadline& deadline) noexcept {
  const TimePoint now = deadline.now();
  // Ipopt's startup: the first Jacobians and a factorisation (no Hessian yet).
  if (startup_estimate == Duration::zero()) startup_estimate = (kJacobianRolloutCost + 2) * start.longest_rollout();
  // An iteration: the Jacobians again and, with the exact Hessian, one more linearisation per
  // state and input coordinate (forward differences), plus a few rollouts of the line search.
  const int linearisations = exact_hessian ? 2 + problem.state_size() + problem.input_size() : 1;
  const Duration modelled_iteration = (kJacobianRolloutCost * linearisations + 2) * start.longest_rollout();
  if (iteration_estimate == Duration::zero()) iteration_estimate = modelled_iteration;
  if (now + startup_estimate + iteration_estimate < deadline.at()) return true;
  // Halved on every skip: one slow start (the very first solve pays Ipopt's one-time setup,
  // ~25 ms) or one stalled iteration must not keep Ipopt from ever running again. The
  // iteration estimate falls by a quarter, and no lower than this solve's model of it, so a
  // vehicle whose iteration never fits the budget skips Ipopt every cycle instead of missing
  // the deadline every few, and one whose model is too low probes every third cycle or so (an
  // iteration that then does not fit is abandoned inside its Hessian, on time).
  startup_estimate /= 2;
  iteration_estimate = std::max(modelled_iteration, iteration_estimate * 3 / 4);
  return false;
}

Ipopt::ApplicationReturnStatus IpoptSolver::Impl::optimize(const OcpProblem& problem, PredictionData& data,
                                                           const Deadline& deadline, const IpoptOptions& options,
                                                           bool* abandoned) {
  // Warm: after a solve on this solver, the primal start (the best guess, normally the shifted
  // plan) is near the optimum, so the barrier starts small; the shifted multipliers too if asked.
  const bool warm = options.warm_start && have_multipliers;
  const bool warm_duals = warm && options.warm_start_multipliers;
  if (warm_duals) nlp->shift_multipliers();
  nlp->prepare(problem, data, best_inputs, best_states, deadline, warm_duals, iteration_estimate);
  Ipopt::OptionsList& ipopt_options = *app->Options();
  ipopt_options.SetStringValue("warm_start_init_point", warm_duals ? "yes" : "no");
  ipopt_options.SetNumericValue("mu_init", warm ? options.warm_mu_init : 0.1);
  if (warm_duals) {
    ipopt_options.SetNumericValue("warm_start_bound_push", 1e-9);
    ipopt_options.SetNumericValue("warm_start_mult_bound_push", 1e-9);
  }
  // Ipopt's own CPU-time limit backs up the intermediate callback on the steady clock; on an
  // injected clock only the callback may stop it (CPU time would make the result nondeterministic).
  const double remaining = deadline.on_steady_clock() ? to_seconds(deadline.remaining()) : kNoCpuTimeLimit;
  ipopt_options.SetNumericValue("max_cpu_time", std::max(1e-6, remaining));
  const TimePoint optimize_start = deadline.now();
  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(GetRawPtr(nlp)));
  if (nlp->first_callback() > optimize_start) {
    startup_estimate = updated_estimate(startup_estimate, nlp->first_callback() - optimize_start);
  }
  if (nlp->longest_step() > Duration::zero()) iteration_estimate = updated_estimate(iteration_estimate, nlp->longest_step());
  *abandoned = nlp->abandoned_iteration() > Duration::zero();
  if (*abandoned) iteration_estimate = std::max(iteration_estimate, nlp->abandoned_iteration());
  return status;
}

namespace {

// Ipopt's return status as the solve's, with the reason; `improved`: its answer beat the best guess.
SolveStatus status_of(Ipopt::ApplicationReturnStatus status, bool improved, SolveSummary* summary) noexcept {
  switch (status) {
    case Ipopt::Solve_Succeeded:
    case Ipopt::Solved_To_Acceptable_Level:
      summary->reason = improved ? "ipopt converged" : "ipopt converged, no better than the initial guess";
      return SolveStatus::kConverged;
    case Ipopt::User_Requested_Stop:
    case Ipopt::Maximum_CpuTime_Exceeded:
      summary->reason = "ipopt stopped at the deadline; the rollout of its last iterate or the best guess";
      return SolveStatus::kBudgetExhausted;
    case Ipopt::Maximum_Iterations_Exceeded:
      summary->reason = "ipopt stopped at max_iterations; the rollout of its last iterate or the best guess";
      return SolveStatus::kBudgetExhausted;
    default:
      summary->reason = "ipopt failed (restoration, infeasibility or evaluation error)";
      return status == Ipopt::Infeasible_Problem_Detected ? SolveStatus::kInfeasible : SolveStatus::kNumericalError;
  }
}

}  // namespace

IpoptSolver::IpoptSolver(const OcpProblem& problem, IpoptOptions options)
    : Solver(problem), options_(std::move(options)) {
  options_.validate();
  const IpoptHessian hessian = options_.hessian == "exact"                ? IpoptHessian::kExact
                               : options_.hessian == "stage-quasi-newton" ? IpoptHessian::kStageQuasiNewton
                                                                          : IpoptHessian::kLimitedMemory;
  impl_ = std::make_unique<Impl>(problem, hessian);
  impl_->startup_estimate = to_duration(options_.startup_estimate);
  Ipopt::IpoptApplication& app = *impl_->app;
  app.Options()->SetStringValue("sb", "yes");  // no banner
  app.Options()->SetIntegerValue("print_level", options_.print_level);
  app.Options()->SetNumericValue("tol", options_.tol);
  app.Options()->SetNumericValue("constr_viol_tol", options_.constr_viol_tol);
  app.Options()->SetNumericValue("acceptable_tol", options_.acceptable_tol);
  app.Options()->SetIntegerValue("max_iter", options_.max_iterations);
  app.Options()->SetStringValue("mu_strategy", options_.mu_strategy);
  app.Options()->SetStringValue("linear_solver", options_.linear_solver);
  if (impl_->hessian_kind != IpoptHessian::kLimitedMemory) {
    app.Options()->SetStringValue("hessian_approximation", "exact");
  } else {
    app.Options()->SetStringValue("hessian_approximation", "limited-memory");
    app.Options()->SetIntegerValue("limited_memory_max_history", options_.lbfgs_history);
  }
  if (app.Initialize() != Ipopt::Solve_Succeeded) throw ConfigError("IpoptSolver: Ipopt failed to initialise");
}

IpoptSolver::~IpoptSolver() = default;

void IpoptSolver::reset_warm_start() noexcept {
  if (impl_ != nullptr) impl_->have_multipliers = false;
}

SolveStatus IpoptSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline,
                                  Solution* out, SolveSummary* summary) noexcept {
  Impl& s = *impl_;
  details_.max_defect = std::numeric_limits<double>::infinity();  // until an iterate says otherwise
  try {
    double best_cost = s.start.choose(problem, guesses, deadline);
    const long rollouts = s.start.rollouts();
    summary->initial_cost = best_cost;
    if (!std::isfinite(best_cost)) {
      summary->reason = "the model failed on every initial guess";
      return SolveStatus::kNumericalError;
    }
    s.best_inputs = s.start.inputs();
    s.best_states = s.start.states();
    s.best_stage_wear = s.start.stage_wear();
    out->inputs = s.best_inputs;
    out->states = s.best_states;
    out->cost = best_cost;
    summary->cost = s.start.breakdown(problem);
    // Ipopt cannot be stopped before its first iterate: when that would overrun the deadline, the
    // best guess is the answer (a usable plan, as the deadline contract asks).
    if (!s.first_iterate_fits(problem, deadline)) {
      summary->iterations = 0;
      summary->rollouts = rollouts;
      summary->reason = "no time for Ipopt's first iterate and one iteration before the deadline; the best initial guess";
      return SolveStatus::kBudgetExhausted;
    }
    bool abandoned = false;
    const Ipopt::ApplicationReturnStatus status = s.optimize(problem, model_data(), deadline, options_, &abandoned);
    summary->iterations = s.nlp->iterations();
    summary->rollouts = s.nlp->evaluations();
    // The final iterate's inputs, rolled out: states that satisfy the dynamics exactly.
    double max_defect = std::numeric_limits<double>::infinity();
    bool improved = false;
    if (s.nlp->final_inputs(&s.inputs, &max_defect)) {
      problem.project(s.inputs);
      const double cost = problem.rollout(model_data(), s.inputs, 0, s.states, s.stage_costs, s.stage_wear.data());
      if (cost <= best_cost) {
        best_cost = cost;
        s.best_inputs = s.inputs;
        s.best_states = s.states;
        s.best_stage_wear = s.stage_wear;
        improved = true;
      }
      s.have_multipliers = true;
    }
    details_.max_defect = max_defect;
    summary->rollouts += rollouts;
    out->inputs = s.best_inputs;
    out->states = s.best_states;
    out->cost = best_cost;
    summary->cost = problem.breakdown(out->inputs, out->states, s.best_stage_wear);
    if (abandoned) {
      summary->reason = "ipopt stopped inside its Hessian at the deadline; the rollout of its last iterate or the best guess";
      return SolveStatus::kBudgetExhausted;
    }
    const SolveStatus solved = status_of(status, improved, summary);
    // Restoration failure, infeasibility, evaluation errors: no trustworthy optimum, so the
    // controller falls back rather than act on it, and the next solve starts cold.
    if (!has_solution(solved)) s.have_multipliers = false;
    return solved;
  } catch (const std::exception&) {
    summary->reason = "ipopt threw an exception";
    return SolveStatus::kNumericalError;
  } catch (...) {
    summary->reason = "ipopt threw an unknown exception";
    return SolveStatus::kNumericalError;
  }
}

}  // namespace swerve
