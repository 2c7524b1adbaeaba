#include "mlspaces/robots/ik.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "mlspaces/core/error.h"
#include "mlspaces/core/se3.h"
#include "mlspaces/sim/mj_pose.h"

namespace mlspaces::robots {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Solves the SPD 6x6 system a x = b in place (Cholesky); a is destroyed.
void Solve6(double a[36], double b[6]) {
  for (int j = 0; j < 6; ++j) {
    double d = a[6 * j + j];
    for (int k = 0; k < j; ++k) d -= a[6 * j + k] * a[6 * j + k];
    d = std::sqrt(std::max(d, 1e-300));
    a[6 * j + j] = d;
    for (int i = j + 1; i < 6; ++i) {
      double s = a[6 * i + j];
      for (int k = 0; k < j; ++k) s -= a[6 * i + k] * a[6 * j + k];
      a[6 * i + j] = s / d;
    }
  }
  for (int i = 0; i < 6; ++i) {  // L y = b
    double s = b[i];
    for (int k = 0; k < i; ++k) s -= a[6 * i + k] * b[k];
    b[i] = s / a[6 * i + i];
  }
  for (int i = 5; i >= 0; --i) {  // L^T x = y
    double s = b[i];
    for (int k = i + 1; k < 6; ++k) s -= a[6 * k + i] * b[k];
    b[i] = s / a[6 * i + i];
  }
}

double Norm6(const double e[6]) {
  return std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3] + e[4] * e[4] +
                   e[5] * e[5]);
}

double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
}

}  // namespace

std::vector<double> DampedLeastSquares(std::span<const double> jac, size_t n,
                                       const std::array<double, 6>& b, double lambda) {
  // A bug check, not bad input: callers build jac from the same n joints.
  if (jac.size() != 6 * n) throw std::logic_error("DampedLeastSquares: jac is not 6 x n");
  double a[36];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      double s = r == c ? lambda * lambda : 0.0;
      for (size_t k = 0; k < n; ++k) s += jac[r * n + k] * jac[c * n + k];
      a[6 * r + c] = s;
    }
  }
  double y[6];
  std::copy(b.begin(), b.end(), y);
  Solve6(a, y);
  std::vector<double> x(n, 0.0);
  for (size_t k = 0; k < n; ++k) {
    for (int r = 0; r < 6; ++r) x[k] += jac[r * n + k] * y[r];
  }
  return x;
}

IkSolver::IkSolver(const mjModel* m, std::string_view site, std::span<const std::string> joints,
                   std::span<const double> rest, IkOptions options)
    : m_(m), d_(sim::MakeData(m)), options_(options) {
  site_ = mj_name2id(m, mjOBJ_SITE, std::string(site).c_str());
  // (mlspaces::Error: inside IkSolver, Error names the member function.)
  if (site_ < 0) throw mlspaces::Error("IK: the model has no site '" + std::string(site) + "'");
  for (const std::string& name : joints) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j < 0) throw mlspaces::Error("IK: the model has no joint '" + name + "'");
    if (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE) {
      throw mlspaces::Error("IK: joint '" + name + "' is not a hinge or slide joint");
    }
    qpos_adr_.push_back(m->jnt_qposadr[j]);
    dof_adr_.push_back(m->jnt_dofadr[j]);
    const bool lim = m->jnt_limited[j] != 0;
    limited_.push_back(lim);
    lower_.push_back(lim ? m->jnt_range[2 * j] : -kPi);
    upper_.push_back(lim ? m->jnt_range[2 * j + 1] : kPi);
  }
  if (rest.empty()) {
    for (size_t i = 0; i < lower_.size(); ++i) {
      rest_.push_back(limited_[i] ? 0.5 * (lower_[i] + upper_[i]) : 0.0);
    }
  } else if (rest.size() != qpos_adr_.size()) {
    throw mlspaces::Error("IK: the rest pose has " + std::to_string(rest.size()) + " values for " +
                          std::to_string(qpos_adr_.size()) + " joints");
  } else {
    rest_.assign(rest.begin(), rest.end());
  }
  jacp_.assign(3 * static_cast<size_t>(m->nv), 0.0);
  jacr_.assign(3 * static_cast<size_t>(m->nv), 0.0);
  mj_resetData(m_, d_.get());
}

void IkSolver::SyncState(const mjData* d) {
  std::copy(d->qpos, d->qpos + m_->nq, d_->qpos);
  std::copy(d->mocap_pos, d->mocap_pos + 3 * m_->nmocap, d_->mocap_pos);
  std::copy(d->mocap_quat, d->mocap_quat + 4 * m_->nmocap, d_->mocap_quat);
}

void IkSolver::SetJoints(std::span<const double> q) {
  for (size_t i = 0; i < q.size(); ++i) d_->qpos[qpos_adr_[i]] = q[i];
  mj_kinematics(m_, d_.get());
}

void IkSolver::Error(const Mat4& target, double e[6]) const {
  const mjtNum* p = d_->site_xpos + 3 * site_;
  const mjtNum* r = d_->site_xmat + 9 * site_;
  for (int c = 0; c < 3; ++c) e[c] = target(c, 3) - p[c];
  std::array<double, 9> rel{};  // R^T R_target
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += r[3 * k + i] * target(k, j);
      rel[3 * i + j] = s;
    }
  }
  const Vec3 w = RotationLog3(rel);  // in the site frame
  for (int c = 0; c < 3; ++c)
    e[3 + c] = r[3 * c] * w[0] + r[3 * c + 1] * w[1] + r[3 * c + 2] * w[2];
}

Mat4 IkSolver::Forward(std::span<const double> q) {
  // A bug check, not bad input: callers size q from this solver's joints.
  if (q.size() != qpos_adr_.size()) throw std::logic_error("IkSolver: q has the wrong size");
  SetJoints(q);
  return sim::SiteMat4(d_.get(), site_);
}

bool IkSolver::Iterate(const Mat4& target, std::vector<double>& q, int& iterations) {
  const size_t n = q.size();
  std::vector<double> jac(6 * n), dq(n), z(n), q_new(n);
  std::vector<bool> locked(n);
  double lambda = options_.damping;
  SetJoints(q);
  double e[6];
  Error(target, e);
  double err = Norm6(e);
  for (int it = 0;; ++it) {
    if (err < options_.tolerance) return true;
    if (it >= options_.max_iterations) return false;
    ++iterations;

    mj_comPos(m_, d_.get());
    mj_jacSite(m_, d_.get(), jacp_.data(), jacr_.data(), site_);
    for (int r = 0; r < 3; ++r) {
      for (size_t c = 0; c < n; ++c) {
        jac[r * n + c] = jacp_[r * m_->nv + dof_adr_[c]];
        jac[(r + 3) * n + c] = jacr_[r * m_->nv + dof_adr_[c]];
      }
    }
    // Active set: a joint at a limit whose step pushes outward is locked (its column and
    // null-space motion removed) and the step recomputed.
    std::fill(locked.begin(), locked.end(), false);
    for (size_t pass = 0; pass <= n; ++pass) {
      Step(jac, e, q, locked, lambda, dq, z);
      bool changed = false;
      for (size_t k = 0; k < n; ++k) {
        if (locked[k] || !limited_[k]) continue;
        if ((q[k] <= lower_[k] + 1e-12 && dq[k] < 0) || (q[k] >= upper_[k] - 1e-12 && dq[k] > 0)) {
          locked[k] = true;
          changed = true;
        }
      }
      if (!changed) break;
    }
    double max_abs = 0;
    for (size_t k = 0; k < n; ++k) max_abs = std::max(max_abs, std::abs(dq[k]));
    const double scale = max_abs > options_.max_step ? options_.max_step / max_abs : 1.0;
    for (size_t k = 0; k < n; ++k) {
      q_new[k] = q[k] + scale * dq[k];
      if (limited_[k]) q_new[k] = std::clamp(q_new[k], lower_[k], upper_[k]);
    }
    // Levenberg-Marquardt acceptance: keep the step if the error drops, else damp more.
    SetJoints(q_new);
    double e_new[6];
    Error(target, e_new);
    const double err_new = Norm6(e_new);
    if (err_new < err) {
      q = q_new;
      std::copy(e_new, e_new + 6, e);
      err = err_new;
      lambda = std::max(options_.damping, 0.5 * lambda);
    } else {
      lambda *= 4;
      if (lambda > 1e3 || max_abs < 1e-14) return false;  // stuck: a local minimum
      SetJoints(q);  // back to the accepted state for the next Jacobian
    }
  }
}

void IkSolver::Step(const std::vector<double>& jac, const double e[6], const std::vector<double>& q,
                    const std::vector<bool>& locked, double lambda, std::vector<double>& dq,
                    std::vector<double>& z) const {
  const size_t n = q.size();
  // dq = z + J^T (J J^T + l^2 I)^-1 (e - J z): the damped least-squares step plus the
  // null-space motion z toward the rest pose; locked columns are left out of J and z.
  double a[36];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      double s = r == c ? lambda * lambda : 0.0;
      for (size_t k = 0; k < n; ++k) {
        if (!locked[k]) s += jac[r * n + k] * jac[c * n + k];
      }
      a[6 * r + c] = s;
    }
  }
  for (size_t k = 0; k < n; ++k) {
    z[k] = locked[k] ? 0.0 : options_.nullspace_gain * (rest_[k] - q[k]);
  }
  double y[6];
  for (int r = 0; r < 6; ++r) {
    double s = e[r];
    for (size_t k = 0; k < n; ++k) s -= jac[r * n + k] * z[k];
    y[r] = s;
  }
  Solve6(a, y);
  for (size_t k = 0; k < n; ++k) {
    if (locked[k]) {
      dq[k] = 0;
      continue;
    }
    double s = z[k];
    for (int r = 0; r < 6; ++r) s += jac[r * n + k] * y[r];
    dq[k] = s;
  }
}

IkResult IkSolver::Solve(const Mat4& target, std::span<const double> seed) {
  if (seed.size() != qpos_adr_.size()) {
    // A bug check, not bad input: callers size the seed from this solver's joints.
    throw std::logic_error("IkSolver: seed has the wrong size");
  }
  const size_t n = seed.size();
  IkResult result;
  std::vector<double> q(seed.begin(), seed.end());
  std::vector<double> best;
  double best_err = INFINITY;
  std::mt19937_64 rng(options_.restart_seed);
  for (int attempt = 0; attempt <= std::max(0, options_.restarts); ++attempt) {
    if (attempt > 0) {
      for (size_t k = 0; k < n; ++k) q[k] = lower_[k] + Uniform01(rng) * (upper_[k] - lower_[k]);
    }
    for (size_t k = 0; k < n; ++k) {
      if (limited_[k]) q[k] = std::clamp(q[k], lower_[k], upper_[k]);
    }
    result.attempts = attempt + 1;
    const bool ok = Iterate(target, q, result.iterations);
    SetJoints(q);
    double e[6];
    Error(target, e);
    const double err = Norm6(e);
    if (ok || err < best_err) {
      best_err = err;
      best = q;
    }
    if (ok) {
      result.success = true;
      break;
    }
  }
  result.q = best;
  const Mat4 reached = Forward(best);
  result.pos_error = TranslationDistance(reached, target);
  result.rot_error = RotationAngle(reached, target);
  return result;
}

}  // namespace mlspaces::robots
