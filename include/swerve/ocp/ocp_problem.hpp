// The wear-aware optimal control problem of one controller cycle: horizon, step, prediction model,
// current state, reference window, cost weights and input bounds. Built once, updated in place
// every cycle (no allocation), and consumed by every solver backend; it knows nothing of YAML.
//
// Cost (docs/paper.md, assumption 6), for inputs u_0..u_{N-1} and predicted states x_1..x_N:
//   sum_k  |pose(x_{k+1}) - pose_ref,k+1|^2_Q  (Q_N = terminal_scale * Q at k+1 = N; pseudo-Huber
//                                              beyond weights.pose_huber_width when it is > 0)
//        + |twist(x_{k+1}) - twist_ref,k+1|^2_Qv
//        + lambda * wear_k                      (tire wear accumulated over step k)
//        + |u_k|^2_R + |u_k - u_{k-1}|^2_S      (u_{-1}: the input applied last cycle)
//        + |x_{k+1}|^2_W                        (W diagonal: a price on states such as the steering rates)
//        + mu (max(0, |e_xy,k+1| - b_k)^2 + max(0, |e_psi,k+1| - c_k)^2)   (the tracking tube)
// Every term but the wear is defined once, as weighted residuals (tracking_residuals,
// effort_root, rate_root): stage k costs 1/2 |r_k|^2 + lambda wear_k. The cost's value, its
// gradient (J^T r) and the Gauss-Newton model of the Ceres backend all derive from them.
// Heading errors are wrapped to (-pi, pi]. The tube (TrackingTolerance in the controller) is an exterior
// penalty on the position and heading errors beyond per-stage bounds b_k, c_k (+inf: no tube,
// the default); mu = weights.tube_penalty is stiff, so inside the tube the wear term rules and
// outside it the tracking does.
#pragma once

#include <Eigen/Core>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/prediction_model.hpp"

namespace swerve {

// The longest horizon any problem, controller or baseline accepts (steps): far beyond a real-time
// horizon, and small enough that a typo cannot make a controller allocate gigabytes.
inline constexpr int kMaxHorizon = 1000;

struct CostWeights {
  Eigen::Vector3d pose{10.0, 10.0, 5.0};  // Q on x, y, psi
  Eigen::Vector3d twist{0.0, 0.0, 0.0};   // Qv on vx, vy, r
  double terminal_scale = 10.0;           // Q_N = terminal_scale * Q
  double wear = 0.0;                      // lambda
  Eigen::VectorXd effort;                 // R, one per input (empty: zeros)
  Eigen::VectorXd rate;                   // S, one per input (empty: zeros)
  // W, one per state (empty: zeros): an effort on predicted states, e.g. the steering rates a
  // prediction with steering lag carries, which the inputs (body twists) do not show.
  Eigen::VectorXd state_effort;
  double tube_penalty = 1e5;              // mu, per m^2 and per rad^2 of error beyond the tube
  // Pseudo-Huber width d of the pose cost (m; 0: quadratic, the default). Beyond d the position cost
  // grows linearly, at the slope the quadratic has at d (Hartley & Zisserman, Multiple View
  // Geometry, 2nd ed., A6.8): Q e^2 becomes 2 Q d^2 (sqrt(1 + (e/d)^2) - 1). The heading's width
  // is the angle that costs what a position error of d costs, d sqrt(Q_xy / Q_psi).
  double pose_huber_width = 0.0;
  // The rules of the fixed-size weights (each >= 0); the per-input and per-state vectors, whose
  // sizes the problem decides, OcpProblem checks itself.
  static const OptionFields<CostWeights>& fields();
};

// Box bounds on every input and a bound on its change per step (|u_k - u_{k-1}| <= max_step;
// +inf for none). Empty vectors mean unbounded.
struct InputBounds {
  Eigen::VectorXd lower, upper, max_step;
};

// The parts of one evaluated cost.
struct CostBreakdown {
  double tracking = 0.0, wear = 0.0, effort = 0.0, rate = 0.0;
  double total() const { return tracking + wear + effort + rate; }
};

class OcpProblem {
 public:
  // Validates sizes and values; throws ConfigError naming the field and value.
  OcpProblem(const PredictionModel& model, int horizon, double dt, CostWeights weights, InputBounds bounds);

  int horizon() const noexcept { return horizon_; }
  double dt() const noexcept { return dt_; }
  int state_size() const noexcept { return nx_; }
  int input_size() const noexcept { return nu_; }
  const PredictionModel& model() const noexcept { return *model_; }
  const CostWeights& weights() const noexcept { return weights_; }
  const InputBounds& bounds() const noexcept { return bounds_; }

  // Per-cycle updates: noexcept, no allocation; false (and nothing changed) on non-finite input
  // or a wrong size.
  bool set_initial_state(const Eigen::Ref<const Eigen::VectorXd>& x0) noexcept;
  bool set_previous_input(const Eigen::Ref<const Eigen::VectorXd>& u_previous) noexcept;
  // Reference for x_k, k = 1..N (column k-1): pose (x, y, psi) and body twist (vx, vy, r).
  bool set_reference(int k, const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body) noexcept;
  // Changes only the wear weight (the lambda sweep and the no-wear comparison use this).
  bool set_wear_weight(double lambda) noexcept;
  // The tracking tube at x_k, k = 1..N: the position error (m) and heading error (rad) beyond which
  // the tube penalty applies; false (nothing changed) unless both are > 0 (+inf: no tube there).
  bool set_tube(int k, double position_bound, double heading_bound) noexcept;
  void clear_tube() noexcept;  // no tube at any stage
  // The position error (m) and the wrapped heading error's magnitude (rad) of state `x` against
  // the reference at x_k, k = 1..N.
  Eigen::Vector2d tracking_error(int k, const Eigen::Ref<const Eigen::VectorXd>& x) const noexcept;
  // The largest excess over the tube of a rolled-out plan (states nx x N+1): position (m) and
  // heading (rad), each >= 0.
  Eigen::Vector2d tube_excess(const Eigen::Ref<const Eigen::MatrixXd>& states) const noexcept;
  const Eigen::Matrix<double, 2, Eigen::Dynamic>& tube() const noexcept { return tube_; }

  const Eigen::VectorXd& initial_state() const noexcept { return x0_; }
  const Eigen::VectorXd& previous_input() const noexcept { return u_previous_; }
  const Eigen::Matrix<double, 3, Eigen::Dynamic>& reference_poses() const noexcept { return reference_pose_; }
  const Eigen::Matrix<double, 3, Eigen::Dynamic>& reference_twists() const noexcept { return reference_twist_; }

  // Makes an input sequence (nu x N) feasible in place: clamps each input to its box, then to its
  // step bound from the previous (already feasible) input. Returns the first step it changed
  // (N if none). noexcept, no allocation.
  int project(Eigen::Ref<Eigen::MatrixXd> inputs) const noexcept;
  bool is_feasible(const Eigen::Ref<const Eigen::MatrixXd>& inputs, double tolerance = 1e-9) const noexcept;

  // Rolls out a (feasible) input sequence from step `first_step`, reusing states(:, 0..first_step)
  // and stage_costs(0..first_step-1) computed earlier for the same prefix; writes states
  // (nx x N+1) and per-stage costs (N). Returns the total cost, or +inf when the model failed.
  // The model steps on `data` (model().create_data()): the problem holds no scratch of its own, so
  // rollouts on separate data may run on separate threads (batched proposals). With `stage_wear`
  // (N entries, or null), each rolled stage's wear is written there too, so breakdown() can report
  // the plan's cost without stepping the model again.
  double rollout(PredictionData& data, const Eigen::Ref<const Eigen::MatrixXd>& inputs, int first_step,
                 Eigen::Ref<Eigen::MatrixXd> states, Eigen::Ref<Eigen::VectorXd> stage_costs,
                 double* stage_wear = nullptr) const noexcept;

  // The tracking residuals of stage k at its end state x_{k+1} (rows: kPoseResidual..): pose error
  // times sqrt(2 s_k Q) (s_k = terminal_scale at k = N-1, else 1), heading wrapped, and with a
  // pseudo-Huber width d times sqrt(2 / (1 + sqrt(1 + (e/d)^2))) (position: e = |e_xy|); twist error
  // times sqrt(2 Qv); the tube's position and heading excess times sqrt(2 mu). With `jacobian`, also
  // d r / d x_{k+1}; it is zero past the pose and twist (kTrackedStates columns). noexcept.
  static constexpr int kPoseResidual = 0, kTwistResidual = 3, kTubeResidual = 6, kTrackingResiduals = 8;
  static constexpr int kTrackedStates = 6;
  using TrackingResiduals = Eigen::Matrix<double, kTrackingResiduals, 1>;
  using TrackingJacobian = Eigen::Matrix<double, kTrackingResiduals, kTrackedStates>;
  void tracking_residuals(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next, TrackingResiduals* residuals,
                          TrackingJacobian* jacobian = nullptr) const noexcept;
  // The input residuals, per input i: effort effort_root[i] * u_k[i] and rate
  // rate_root[i] * (u_k[i] - u_{k-1}[i]), with effort_root = sqrt(2 R) and rate_root = sqrt(2 S).
  const Eigen::VectorXd& effort_root() const noexcept { return effort_root_; }
  // The state-effort residuals: state_effort_root()[j] * x_{k+1}[state_effort_index()[j]], one per
  // state with a weight > 0 (sqrt(2 W)).
  const Eigen::VectorXi& state_effort_index() const noexcept { return state_effort_index_; }
  const Eigen::VectorXd& state_effort_root() const noexcept { return state_effort_root_; }
  const Eigen::VectorXd& rate_root() const noexcept { return rate_root_; }

  // Cost of stage k without its wear term: tracking at x_{k+1}, effort on u_k and rate on
  // u_k - u_{k-1} (u_{-1}: previous_input()). Its gradient is written (not added) to d_x_next (nx),
  // d_u and d_u_before (nu); the heading error is wrapped, so its derivative is 1. Used by the
  // gradient backends with the wear term's derivative from the model. noexcept, no allocation.
  double stage_cost_without_wear(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next,
                                 const Eigen::Ref<const Eigen::VectorXd>& u,
                                 const Eigen::Ref<const Eigen::VectorXd>& u_before, Eigen::Ref<Eigen::VectorXd> d_x_next,
                                 Eigen::Ref<Eigen::VectorXd> d_u, Eigen::Ref<Eigen::VectorXd> d_u_before) const noexcept;

  // One full evaluation (a rollout on `data`) with the cost split into its parts (for reports, not
  // the hot loop).
  CostBreakdown evaluate(PredictionData& data, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                         Eigen::Ref<Eigen::MatrixXd> states) const noexcept;
  // The same split for a plan already rolled out: `states` (nx x N+1) and `stage_wear` (N) as
  // rollout() wrote them for `inputs`. No model step, so a solver on a deadline can report its
  // answer's cost for the price of the cost terms alone (a rollout near standstill costs 10x one in
  // cruise, and re-rolling the answer overran SA's deadline by up to 1.5 ms).
  CostBreakdown breakdown(const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                          const Eigen::Ref<const Eigen::MatrixXd>& states,
                          const Eigen::Ref<const Eigen::VectorXd>& stage_wear) const noexcept;

 private:
  // u_{k-1}: the previous cycle's input for k = 0.
  Eigen::Ref<const Eigen::VectorXd> input_before(const Eigen::Ref<const Eigen::MatrixXd>& inputs, int k) const noexcept;
  // 1/2 |x_{k+1}|^2_W, the state effort (counted with the effort in CostBreakdown).
  double state_effort(const Eigen::Ref<const Eigen::VectorXd>& x_next) const noexcept;
  double stage_cost(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next, const Eigen::Ref<const Eigen::VectorXd>& u,
                    const Eigen::Ref<const Eigen::VectorXd>& u_before, double wear, CostBreakdown* parts) const noexcept;

  const PredictionModel* model_;
  int horizon_, nx_, nu_;
  double dt_;
  CostWeights weights_;
  InputBounds bounds_;
  Eigen::VectorXd x0_;                                    // nx
  Eigen::VectorXd u_previous_;                            // nu
  Eigen::Matrix<double, 3, Eigen::Dynamic> reference_pose_;   // 3 x N
  Eigen::Matrix<double, 3, Eigen::Dynamic> reference_twist_;  // 3 x N
  Eigen::Matrix<double, 2, Eigen::Dynamic> tube_;             // 2 x N: position, heading bounds
  // The residuals' weights: square roots of twice each weight (1/2 r^2 is the weighted square).
  Eigen::Vector3d pose_root_, terminal_pose_root_, twist_root_;
  double tube_root_ = 0.0;
  // Pseudo-Huber widths of the position (m) and heading (rad) errors; 0: quadratic.
  double position_huber_width_ = 0.0, heading_huber_width_ = 0.0;
  Eigen::VectorXd effort_root_, rate_root_;  // nu
  Eigen::VectorXi state_effort_index_;        // m: the states with a weight in state_effort
  Eigen::VectorXd state_effort_root_;         // m: sqrt(2 W) of each
};

}  // namespace swerve
