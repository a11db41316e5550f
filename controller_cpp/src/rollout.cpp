// The compiled rollout on MuJoCo (module revolve_env._rollout): a whole evaluation (Rollout), and
// one control period of a whole world (WorldStep).
//
// A whole evaluation (insertion, then the fitness window) of robots that each live in a MuJoCo
// scene of their own (an isolated world), with no Python per control period: RoboGen's servo law,
// mj_step, the body states, the core IMU, touch and light sensors, the blow-up screen, the brain
// (revolve::BatchController, one per robot) and the core's path, all in C++ with the GIL released,
// the robots spread over a few threads. It follows the NumPy rules of revolve_env/world (world.py,
// sensing.py, blowups.py, mujoco_scenes.py) operation for operation, so that every number is the
// one the NumPy path gives, bit for bit: the file is compiled without contraction
// (-ffp-contract=off), and std::fma is written where NumPy's kernels fuse (measured; the Python
// side checks these formulas against NumPy at import and keeps the NumPy path where they differ).
//
// What the rules decide in Python stays there: a robot whose blow-up screen fails stops (SCREEN)
// until Python has computed its reason (revolve_env.world.blowups.reason) and resumes or drops it;
// a robot whose state turns non-finite, whose brain's outputs are not finite or whose mj_step
// fails stops for good (FALLBACK), and Python evaluates it again on the NumPy path, which replays
// and reports such periods as ever.
//
// WorldStep is one control period of every robot of one MuJoCo scene (a World that the envs step
// period by period): the servo law on the world's targets, the substeps, the body states, the
// sensors and the blow-up screen's calm test in one call, by the same rules (the functions below
// are the one home of each rule for both). What is rare stays in Python as in Rollout: a period
// whose physics fails or turns non-finite is replayed by MujocoBackend, a failed screen is judged
// robot by robot by blowups.reason.
#include <mujoco/mujoco.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "revolve/batch_controller.hpp"
#include "revolve/network_view.hpp"

// Exported by libmujoco (used the same way by MuJoCo's own Python bindings): a log handler for the
// calling thread only, so an mju_error inside mj_step comes back here instead of ending the process.
extern "C" MJAPI mjfLogHandler _mjPRIVATE_setTlsLogHandler(mjfLogHandler handler);
extern "C" MJAPI mjfLogHandler _mjPRIVATE_getGlobalLogHandler(void);

namespace nb = nanobind;

namespace {

enum Status : int { kRunning = 0, kDone = 1, kScreen = 2, kFallback = 3 };

thread_local std::jmp_buf* t_jump = nullptr;

void on_log(const mjLogMessage* msg) {
    if (msg->level == mjLOG_ERROR && t_jump != nullptr) std::longjmp(*t_jump, 1);
    mjfLogHandler global = _mjPRIVATE_getGlobalLogHandler();
    if (global != nullptr) global(msg);  // warnings go where they would have gone
}

// One physics step; false if MuJoCo raised an error (the data is then half-updated).
bool guarded_step(const mjModel* m, mjData* d) {
    std::jmp_buf buf;
    std::jmp_buf* outer = t_jump;
    t_jump = &buf;
    if (setjmp(buf) != 0) {
        t_jump = outer;
        return false;
    }
    mj_step(m, d);
    t_jump = outer;
    return true;
}

bool finite(const double* a, int n) {
    for (int i = 0; i < n; ++i) {
        if (!std::isfinite(a[i])) return false;
    }
    return true;
}

// np.maximum / np.minimum: NaN in either argument gives NaN.
inline double np_max(double a, double b) { return (a != a || a >= b) ? a : b; }
inline double np_min(double a, double b) { return (a != a || a <= b) ? a : b; }

// glibc's pow, never replaced by x * x (NumPy's float_power calls it).
double (*volatile libm_pow)(double, double) = static_cast<double (*)(double, double)>(&std::pow);

// The kernels, shared by the rollout and by the probes that check them against NumPy at import.

// (2, 3) @ (3, 3), row vectors times the core's rotation (sensing.imu_readings' stacked matmul):
// OpenBLAS's kernel fuses the products, first term first.
inline void imu_product(const double rows[6], const double* R, double out[6]) {
    for (int a = 0; a < 2; ++a) {
        const double* v = rows + 3 * a;
        for (int j = 0; j < 3; ++j) out[3 * a + j] = std::fma(v[2], R[6 + j], std::fma(v[1], R[3 + j], v[0] * R[j]));
    }
}

// R @ w as NumPy's einsum("nij,nj->ni") sums it (terms 0 and 2, then 1): the core's angular
// velocity in the world frame from MuJoCo's body-frame one (MujocoBackend.read).
inline void einsum_product(const double* R, const double* w, double out[3]) {
    for (int i = 0; i < 3; ++i) out[i] = (R[3 * i] * w[0] + R[3 * i + 2] * w[2]) + R[3 * i + 1] * w[1];
}

// sensing.light_intensity for one sensor: link pose (pos, R), sensing point and facing in the link.
inline double light_value(const double* pos, const double* M, const double* point, const double* facing_in,
                          const double* light, double light_range) {
    double where[3], facing[3], to[3];
    // (3, 3) @ (3, 1): this kernel sums term 1, then fuses 0, then 2.
    for (int i = 0; i < 3; ++i) {
        const double* row = M + 3 * i;
        where[i] = pos[i] + std::fma(row[2], point[2], std::fma(row[0], point[0], row[1] * point[1]));
        facing[i] = std::fma(row[2], facing_in[2], std::fma(row[0], facing_in[0], row[1] * facing_in[1]));
    }
    for (int i = 0; i < 3; ++i) to[i] = light[i] - where[i];
    const double dist = std::sqrt((to[0] * to[0] + to[1] * to[1]) + to[2] * to[2]);  // np.vecdot
    double cos_a = 1.0;
    if (dist > 0) cos_a = ((facing[0] * to[0] + facing[1] * to[1]) + facing[2] * to[2]) / dist;
    const double spread = 1.0 + libm_pow(dist / light_range, 2.0);
    return (cos_a > 0 ? cos_a : 0.0) / spread;
}

// sensing.light_falloff: what a light sensor at ``pos`` facing the light reads.
inline double falloff_value(const double* pos, const double* light, double light_range) {
    double to[3];
    for (int i = 0; i < 3; ++i) to[i] = light[i] - pos[i];
    const double dist = std::sqrt((to[0] * to[0] + to[1] * to[1]) + to[2] * to[2]);
    return 1.0 / (1.0 + libm_pow(dist / light_range, 2.0));
}

struct Settings {
    bool light_signal = false;  // record the task signal "light" (signals.LightSignal)
    int insertion_ticks = 0, evaluation_ticks = 0, brain_stride = 1, substeps = 1;
    double control_period = 0, servo_k = 0, max_velocity = 0, target_scale = 0, gravity = 0;
    double inv_period = 0;  // 1.0 / control_period, as Python computes it
    double imu_high[6] = {0, 0, 0, 0, 0, 0};
    double light[3] = {0, 0, 0};
    double light_range = 1;
};

struct Light {
    int body;  // -1: on the core (reads the core's pose)
    int dest;
    double point[3], facing[3];
    int row = 0;  // WorldStep: the robot whose core it is on (body -1)
};

// The rules of one control period, the one home of each for Rollout and WorldStep.

// RoboGen's servo law (World.step): the commanded velocity of an active hinge at angle q.
inline double servo_velocity(double k, double target, double q, double vmax) {
    return np_min(np_max(k * (target - q), -vmax), vmax);
}

// sensing.imu_readings of one core, saturated at IMU_HIGH: R its rotation, v its velocity and w its
// angular velocity (world frame), prev its velocity one control period ago (imu_values on MuJoCo,
// sense_rows on pybullet's arrays).
inline void imu_reading(const double* R, const double* v, const double* w, const double prev[3], const Settings& s,
                        double out[6]) {
    double rows[6], imu[6];
    for (int k = 0; k < 3; ++k) rows[k] = (v[k] - prev[k]) * s.inv_period;
    rows[2] += s.gravity;
    for (int k = 0; k < 3; ++k) rows[3 + k] = w[k];
    imu_product(rows, R, imu);
    for (int k = 0; k < 6; ++k) out[k] = np_min(np_max(imu[k], -s.imu_high[k]), s.imu_high[k]);
}

// World._sense's IMU of one core (sensing.imu_readings, saturated at IMU_HIGH); prev: the core's
// velocity one control period ago.
inline void imu_values(const mjData* d, int root_body, int root_dof, const double prev[3], const Settings& s,
                       double out[6]) {
    const double* R = d->xmat + 9 * root_body;
    const double* v = d->qvel + root_dof;
    double w[3];
    einsum_product(R, v + 3, w);  // the core's angular velocity in the world frame
    imu_reading(R, v, w, prev, s, out);
}

// MujocoBackend._touching_now: which bodies of the scene touch anything (touched: one per body).
inline void mark_contacts(const mjModel* m, const mjData* d, std::vector<char>& touched) {
    std::fill(touched.begin(), touched.end(), 0);
    for (int c = 0; c < d->ncon; ++c) {
        touched[m->geom_bodyid[d->contact[c].geom[0]]] = 1;
        touched[m->geom_bodyid[d->contact[c].geom[1]]] = 1;
    }
}

// What one light sensor reads (World._sense: a sensor on a core reads the core's pose).
inline double light_reading(const mjData* d, int root_qpos, int root_body, const Light& L, const Settings& s) {
    const double* pos = L.body < 0 ? d->qpos + root_qpos : d->xpos + 3 * L.body;
    const double* M = d->xmat + 9 * (L.body < 0 ? root_body : L.body);
    return light_value(pos, M, L.point, L.facing, s.light, s.light_range);
}

// blowups.Screen's per-entry limits (inverses) of one robot's entries.
struct ScreenView {
    const double *vel, *spin, *hinge_vel, *pos, *hinge_pos;
};

// blowups.all_calm's test of one robot's entries: p, v, w its core's position, velocity and
// angular velocity (world frame), q(i) and qd(i) its i-th hinge's angle and speed (calm on MuJoCo,
// all_calm_rows on pybullet's arrays).
template <class Angle, class Speed>
inline bool calm_entries(const double* p, const double* v, const double* w, int J, Angle q, Speed qd,
                         const ScreenView& sc) {
    bool ok = true;
    for (int i = 0; i < 3; ++i) ok &= std::fabs(v[i]) * sc.vel[i] <= 1.0;
    for (int i = 0; i < 3; ++i) ok &= std::fabs(w[i]) * sc.spin[i] <= 1.0;
    for (int i = 0; i < J; ++i) ok &= std::fabs(qd(i)) * sc.hinge_vel[i] <= 1.0;
    for (int i = 0; i < 3; ++i) ok &= std::fabs(p[i]) * sc.pos[i] <= 1.0;
    for (int i = 0; i < J; ++i) ok &= std::fabs(q(i)) * sc.hinge_pos[i] <= 1.0;
    return ok && p[2] >= -0.999;
}

// blowups.all_calm for one robot: every entry within its screen, the core above -0.999 m; w: the
// core's angular velocity in the world frame. A NaN fails (a conjunction: the order is free).
inline bool calm(const mjData* d, int root_qpos, int root_dof, const double w[3], const int* hinge_qpos,
                 const int* hinge_dof, int J, const ScreenView& sc) {
    return calm_entries(
        d->qpos + root_qpos, d->qvel + root_dof, w, J, [&](int i) { return d->qpos[hinge_qpos[i]]; },
        [&](int i) { return d->qvel[hinge_dof[i]]; }, sc);
}

enum Physics { kStepped = 0, kNonFinite = 1, kFailed = 2 };

// The substeps of a control period. MujocoBackend.step looks at the state once, after the last
// substep (each = false); Rollout stops at the first non-finite substep (each = true).
inline Physics physics(const mjModel* m, mjData* d, int substeps, bool each) {
    for (int k = 0; k < substeps; ++k) {
        if (!guarded_step(m, d)) return kFailed;
        if (each && (!finite(d->qpos, m->nq) || !finite(d->qvel, m->nv))) return kNonFinite;
    }
    if (!each && (!finite(d->qvel, m->nv) || !finite(d->qpos, m->nq))) return kNonFinite;
    return kStepped;
}

// One robot in its own scene: its model and data (owned by Python), where to find it in them,
// its brain, and its evaluation so far.
struct Robot {
    const mjModel* m = nullptr;
    mjData* d = nullptr;
    int root_body = 0, root_qpos = 0, root_dof = 0;
    std::vector<int> hinge_qpos, hinge_dof;  // every hinge, joint order (the screen)
    std::vector<int> active;                 // hinge of each output, output order
    std::vector<int> touch_body, touch_dest;
    std::vector<Light> lights;
    std::vector<double> screen;  // blowups.Screen(1, hinges).inverse
    std::unique_ptr<revolve::BatchController> brain;
    std::vector<double> inputs, outputs, targets;
    std::vector<char> touched;  // per body of the scene
    double prev_vel[3] = {0, 0, 0};
    double time = 0.0;
    int tick = 0;
    bool pending_record = false;  // resumed after a screen: the period's record is still due
    int status = kRunning;
    std::vector<double> path;  // recorded core positions, (rows, 3)
    std::vector<double> signal;  // the task's signal at the same rows
    int rows = 0;
};

class Rollout {
   public:
    explicit Rollout(const Settings& s) : s_(s) {}
    Rollout(const Rollout&) = delete;  // owns its robots' brains
    Rollout& operator=(const Rollout&) = delete;

    Settings s_;
    std::vector<Robot> robots_;

    // Runs every robot that is running until it is done or stops; the robots over `threads`
    // threads (each robot on one thread at a time: its result does not depend on the split).
    // Called without the GIL; between two robots the calling thread takes it to see Ctrl-C, and
    // returns false (a Python error set) when a signal handler raised.
    bool run(int threads) {
        std::vector<int> todo;
        for (int i = 0; i < static_cast<int>(robots_.size()); ++i) {
            if (robots_[i].status == kRunning) todo.push_back(i);
        }
        std::atomic<int> next{0};
        std::atomic<bool> interrupted{false};
        auto work = [&](bool caller) {
            mjfLogHandler outer = _mjPRIVATE_setTlsLogHandler(&on_log);
            for (int k = next.fetch_add(1); k < static_cast<int>(todo.size()) && !interrupted;
                 k = next.fetch_add(1)) {
                advance(robots_[todo[k]]);
                if (caller) {
                    nb::gil_scoped_acquire gil;
                    if (PyErr_CheckSignals() != 0) interrupted = true;
                }
            }
            _mjPRIVATE_setTlsLogHandler(outer);
        };
        int n = threads < 1 ? 1 : threads;
        if (n > static_cast<int>(todo.size())) n = static_cast<int>(todo.size());
        std::vector<std::thread> pool;
        for (int t = 1; t < n; ++t) pool.emplace_back(work, false);
        work(true);
        for (auto& t : pool) t.join();
        return !interrupted;
    }

   private:
    void record(Robot& r) {
        const double* q = r.d->qpos + r.root_qpos;
        r.path.insert(r.path.end(), q, q + 3);
        ++r.rows;
        if (s_.light_signal) r.signal.push_back(light_signal(r));
    }

    // signals.LightSignal: the brightest light sensor, else the light at the core.
    double light_signal(const Robot& r) const {
        const double* core = r.d->qpos + r.root_qpos;
        if (r.lights.empty()) return falloff_value(core, s_.light, s_.light_range);
        double best = 0.0;
        bool first = true;
        for (const Light& L : r.lights) {
            const double v = light_reading(r.d, r.root_qpos, r.root_body, L, s_);
            best = first ? v : np_max(best, v);  // np.maximum.reduceat: NaN wins
            first = false;
        }
        return best;
    }

    // The core's angular velocity in the world frame: xmat @ (body-frame qvel), summed as NumPy's
    // einsum("nij,nj->ni") sums (terms 0 and 2, then 1).
   public:
    static void angvel(const Robot& r, double out[3]) {
        einsum_product(r.d->xmat + 9 * r.root_body, r.d->qvel + r.root_dof + 3, out);
    }

   private:

    // World._sense for one robot (sensing.imu_readings, light_intensity; backend touching).
    void sense(Robot& r) {
        double* out = r.inputs.data();
        imu_values(r.d, r.root_body, r.root_dof, r.prev_vel, s_, out);
        if (!r.touch_body.empty()) {
            mark_contacts(r.m, r.d, r.touched);
            for (std::size_t k = 0; k < r.touch_body.size(); ++k) {
                out[r.touch_dest[k]] = r.touched[r.touch_body[k]] ? 1.0 : 0.0;
            }
        }
        for (const Light& L : r.lights) out[L.dest] = light_reading(r.d, r.root_qpos, r.root_body, L, s_);
    }

    // blowups.all_calm for one robot (its Screen(1, hinges).inverse).
    static bool calm(const Robot& r, const double* w) {
        const double* sc = r.screen.data();
        const int J = static_cast<int>(r.hinge_qpos.size());
        return ::calm(r.d, r.root_qpos, r.root_dof, w, r.hinge_qpos.data(), r.hinge_dof.data(), J,
                      ScreenView{sc, sc + 3, sc + 6, sc + 6 + J, sc + 9 + J});
    }

    // One control period; false when the robot stopped (its status says why).
    bool period(Robot& r) {
        const mjModel* m = r.m;
        mjData* d = r.d;
        if (r.tick == s_.insertion_ticks) record(r);
        const int n_out = static_cast<int>(r.active.size());
        if (r.tick % s_.brain_stride == 0) {
            sense(r);
            r.brain->step(r.inputs.data(), r.outputs.data());
            // World._write_targets: clipped and scaled; a non-finite target is the NumPy path's
            if (!finite(r.outputs.data(), n_out)) {
                r.status = kFallback;
                return false;
            }
            for (int i = 0; i < n_out; ++i) {
                r.targets[i] = np_min(np_max(r.outputs[i], -1.0), 1.0) * s_.target_scale;
            }
        }
        for (int i = 0; i < n_out; ++i) {
            d->ctrl[i] = servo_velocity(s_.servo_k, r.targets[i], d->qpos[r.hinge_qpos[r.active[i]]], s_.max_velocity);
        }
        for (int k = 0; k < 3; ++k) r.prev_vel[k] = d->qvel[r.root_dof + k];
        // A non-finite state is the NumPy path's to replay and report (MujocoBackend._replay).
        if (physics(m, d, s_.substeps, true) != kStepped || !finite(d->qacc_warmstart, m->nv)) {
            r.status = kFallback;
            return false;
        }
        mj_kinematics(m, d);  // as MujocoScenes.step: the poses of the state now
        r.time += s_.control_period;
        double w[3];
        angvel(r, w);
        if (!calm(r, w)) {
            r.status = kScreen;
            r.pending_record = true;
            return false;
        }
        finish(r);
        return true;
    }

    void finish(Robot& r) {
        if (r.tick >= s_.insertion_ticks) record(r);
        ++r.tick;
        if (r.tick >= s_.insertion_ticks + s_.evaluation_ticks) r.status = kDone;
    }

   public:
    void advance(Robot& r) {
        if (r.pending_record) {
            r.pending_record = false;
            finish(r);
        }
        while (r.status == kRunning && period(r)) {
        }
    }

    // After a SCREEN stop: Python found the robot blown (drop) or not (go on).
    void resume(int i, bool blown) {
        Robot& r = robot(i);
        if (r.status != kScreen) throw std::invalid_argument("robot is not waiting for a screen");
        if (blown) {
            r.pending_record = false;
            r.status = kDone;
        } else {
            r.status = kRunning;
        }
    }

    Robot& robot(int i) {
        if (i < 0 || i >= static_cast<int>(robots_.size())) throw std::out_of_range("no such robot");
        return robots_[i];
    }
};

// One control period of every robot of one MuJoCo scene (World.step on MujocoBackend), with the
// world's sensors and blow-up screen after it. The scene's model and data belong to Python; a
// WorldStep is made again whenever they or the robots change (a birth, a death, a restore).
class WorldStep {
   public:
    // What a period left for Python: all calm; a failed screen (blowups.reason judges each robot);
    // a non-finite state or a failed mj_step (MujocoBackend replays the period from `start`).
    enum Outcome : int { kCalm = 0, kUnsettled = 1, kReplay = 2, kRestart = 3 };

    Settings s_;
    const mjModel* m_ = nullptr;
    mjData* d_ = nullptr;
    int n_ = 0, J_ = 0, n_inputs_ = 0;
    std::vector<int> root_body_, root_qpos_, root_dof_, hinge_qpos_, hinge_dof_, joint_start_, input_start_;
    std::vector<int> ctrl_qpos_;  // qpos of the hinge of each actuator (World's active_index)
    std::vector<int> touch_body_, touch_dest_;
    std::vector<Light> lights_;
    std::vector<double> screen_;  // blowups.Screen(n, J).inverse
    std::vector<char> touched_;

    int state_size() const { return mj_stateSize(m_, kSaved); }

    // The flat layout of `states`: core_pos (n, 3), core_rot (n, 3, 3), core_vel (n, 3),
    // core_angvel (n, 3), joint_pos (J,), joint_vel (J,), then the cores' velocities before the
    // period (n, 3): BodyStates' fields and the IMU's previous velocities.
    std::size_t states_size() const { return static_cast<std::size_t>(21 * n_ + 2 * J_); }

    int step(const double* targets, double* start, double* states, double* sensors) {
        const mjModel* m = m_;
        mjData* d = d_;
        for (int i = 0; i < m->nu; ++i) {
            d->ctrl[i] = servo_velocity(s_.servo_k, targets[i], d->qpos[ctrl_qpos_[i]], s_.max_velocity);
        }
        double* pos = states;
        double* rot = pos + 3 * n_;
        double* vel = rot + 9 * n_;
        double* spin = vel + 3 * n_;
        double* jpos = spin + 3 * n_;
        double* jvel = jpos + J_;
        double* prev = jvel + J_;
        for (int r = 0; r < n_; ++r) std::memcpy(prev + 3 * r, d->qvel + root_dof_[r], 3 * sizeof(double));
        mj_getState(m, d, start, kSaved);  // the period's start, should it need a replay
        Physics outcome;
        {
            mjfLogHandler outer = _mjPRIVATE_setTlsLogHandler(&on_log);
            outcome = physics(m, d, s_.substeps, false);
            _mjPRIVATE_setTlsLogHandler(outer);
        }
        if (outcome == kFailed) return kRestart;
        if (outcome == kNonFinite) return kReplay;
        mj_kinematics(m, d);  // the poses of the state now (MujocoBackend.read)
        for (int r = 0; r < n_; ++r) {
            std::memcpy(pos + 3 * r, d->qpos + root_qpos_[r], 3 * sizeof(double));
            std::memcpy(rot + 9 * r, d->xmat + 9 * root_body_[r], 9 * sizeof(double));
            std::memcpy(vel + 3 * r, d->qvel + root_dof_[r], 3 * sizeof(double));
            einsum_product(d->xmat + 9 * root_body_[r], d->qvel + root_dof_[r] + 3, spin + 3 * r);
        }
        for (int j = 0; j < J_; ++j) {
            jpos[j] = d->qpos[hinge_qpos_[j]];
            jvel[j] = d->qvel[hinge_dof_[j]];
        }
        // World._sense
        for (int r = 0; r < n_; ++r) imu_values(d, root_body_[r], root_dof_[r], prev + 3 * r, s_, sensors + input_start_[r]);
        if (!touch_body_.empty()) {
            mark_contacts(m, d, touched_);
            for (std::size_t k = 0; k < touch_body_.size(); ++k) {
                sensors[touch_dest_[k]] = touched_[touch_body_[k]] ? 1.0 : 0.0;
            }
        }
        for (const Light& L : lights_) {
            sensors[L.dest] = light_reading(d, root_qpos_[L.row], root_body_[L.row], L, s_);
        }
        // World._check_blow_ups' screen
        const double* sc = screen_.data();
        bool ok = true;
        for (int r = 0; r < n_ && ok; ++r) {
            const int j0 = joint_start_[r], J = joint_start_[r + 1] - j0;
            const ScreenView view{sc + 3 * r, sc + 3 * n_ + 3 * r, sc + 6 * n_ + j0, sc + 6 * n_ + J_ + 3 * r,
                                  sc + 9 * n_ + J_ + j0};
            ok = calm(d, root_qpos_[r], root_dof_[r], spin + 3 * r, hinge_qpos_.data() + j0, hinge_dof_.data() + j0, J,
                      view);
        }
        return ok ? kCalm : kUnsettled;
    }

    // mjSTATE_TIME | QPOS | QVEL | WARMSTART: MujocoBackend's _SAVED, what a replay starts from.
    static constexpr int kSaved = mjSTATE_TIME | mjSTATE_QPOS | mjSTATE_QVEL | mjSTATE_WARMSTART;
};

template <typename T>
using Vec = nb::ndarray<const T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Mat3 = nb::ndarray<const double, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>;

std::vector<int> ints(const Vec<std::int64_t>& a) {
    return std::vector<int>(a.data(), a.data() + a.shape(0));
}

void check_index(const std::vector<int>& v, int limit, const char* what) {
    for (int x : v) {
        if (x < 0 || x >= limit) throw nb::value_error((std::string(what) + " out of range").c_str());
    }
}

using revolve::network_view;  // revolve/network_view.hpp: one home for both extensions

int add(Rollout& ro, std::uintptr_t model, std::uintptr_t data, int root_body, int root_qpos, int root_dof,
        Vec<std::int64_t> hinge_qpos, Vec<std::int64_t> hinge_dof, Vec<std::int64_t> active, int n_inputs,
        Vec<std::int64_t> touch_body, Vec<std::int64_t> touch_dest, Vec<std::int64_t> light_body,
        Vec<std::int64_t> light_dest, Mat3 light_point, Mat3 light_facing, Vec<double> screen,
        Vec<double> prev_vel, Vec<std::int8_t> kinds, nb::ndarray<const double, nb::ndim<2>, nb::c_contig> params,
        Vec<std::int32_t> src, Vec<std::int32_t> dst, Vec<double> weight, std::int64_t net_inputs,
        std::int64_t net_outputs, double brain_dt) {
    Robot r;
    r.m = reinterpret_cast<const mjModel*>(model);
    r.d = reinterpret_cast<mjData*>(data);
    if (r.m == nullptr || r.d == nullptr) throw nb::value_error("null MuJoCo model or data");
    const mjModel* m = r.m;
    if (root_body < 0 || root_body >= m->nbody || root_qpos < 0 || root_qpos + 7 > m->nq || root_dof < 0 ||
        root_dof + 6 > m->nv) {
        throw nb::value_error("the robot's root is not in the model");
    }
    r.root_body = root_body;
    r.root_qpos = root_qpos;
    r.root_dof = root_dof;
    r.hinge_qpos = ints(hinge_qpos);
    r.hinge_dof = ints(hinge_dof);
    r.active = ints(active);
    check_index(r.hinge_qpos, m->nq, "hinge qpos");
    check_index(r.hinge_dof, m->nv, "hinge dof");
    if (r.hinge_qpos.size() != r.hinge_dof.size()) throw nb::value_error("hinge addresses differ in length");
    check_index(r.active, static_cast<int>(r.hinge_qpos.size()), "active hinge");
    if (static_cast<int>(r.active.size()) != m->nu) throw nb::value_error("one actuator per active hinge expected");
    r.touch_body = ints(touch_body);
    r.touch_dest = ints(touch_dest);
    check_index(r.touch_body, m->nbody, "touch body");
    check_index(r.touch_dest, n_inputs, "touch input");
    if (r.touch_body.size() != r.touch_dest.size()) throw nb::value_error("touch arrays differ in length");
    const std::size_t k = light_body.shape(0);
    if (light_dest.shape(0) != k || light_point.shape(0) != k || light_facing.shape(0) != k) {
        throw nb::value_error("light arrays differ in length");
    }
    for (std::size_t i = 0; i < k; ++i) {
        Light L{static_cast<int>(light_body(i)), static_cast<int>(light_dest(i)), {}, {}};
        if (L.body < -1 || L.body >= m->nbody || L.dest < 0 || L.dest >= n_inputs) {
            throw nb::value_error("light sensor out of range");
        }
        for (int j = 0; j < 3; ++j) {
            L.point[j] = light_point(i, j);
            L.facing[j] = light_facing(i, j);
        }
        r.lights.push_back(L);
    }
    const std::size_t J = r.hinge_qpos.size();
    if (screen.shape(0) != 6 + 2 * J + 3 || prev_vel.shape(0) != 3) throw nb::value_error("bad screen or velocity");
    r.screen.assign(screen.data(), screen.data() + screen.shape(0));
    for (int j = 0; j < 3; ++j) r.prev_vel[j] = prev_vel(j);
    if (n_inputs < 6 || net_inputs != n_inputs || net_outputs != static_cast<std::int64_t>(r.active.size())) {
        throw nb::value_error("the network does not fit the body");
    }
    r.brain = std::make_unique<revolve::BatchController>(brain_dt);
    r.brain->add(network_view(kinds, params, src, dst, weight, net_inputs, net_outputs));
    r.inputs.assign(n_inputs, 0.0);
    r.outputs.assign(r.active.size(), 0.0);
    r.targets.assign(r.active.size(), 0.0);
    r.touched.assign(m->nbody, 0);
    r.path.reserve(3 * (ro.s_.evaluation_ticks + 1));
    ro.robots_.push_back(std::move(r));
    return static_cast<int>(ro.robots_.size()) - 1;
}

// The physics settings both the rollout and the world step take (their one home), checked:
// `what` names the caller's settings in the error.
void set_physics(Settings& s, int substeps, double control_period, double servo_k, double max_velocity,
                 double gravity, const Vec<double>& imu_high, const Vec<double>& light, double light_range,
                 const char* what) {
    if (substeps < 1 || !(control_period > 0) || imu_high.shape(0) != 6 || light.shape(0) != 3) {
        throw nb::value_error(what);
    }
    s.substeps = substeps;
    s.control_period = control_period;
    s.inv_period = 1.0 / control_period;
    s.servo_k = servo_k;
    s.max_velocity = max_velocity;
    s.gravity = gravity;
    for (int i = 0; i < 6; ++i) s.imu_high[i] = imu_high(i);
    for (int i = 0; i < 3; ++i) s.light[i] = light(i);
    s.light_range = light_range;
}

using Out = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

void make_world_step(WorldStep* self, std::uintptr_t model, std::uintptr_t data, int substeps, double control_period,
                     double servo_k, double max_velocity, double gravity, Vec<double> imu_high, Vec<double> light,
                     double light_range, Vec<std::int64_t> root_body, Vec<std::int64_t> root_qpos,
                     Vec<std::int64_t> root_dof, Vec<std::int64_t> hinge_qpos, Vec<std::int64_t> hinge_dof,
                     Vec<std::int64_t> joint_start, Vec<std::int64_t> input_start, int n_inputs,
                     Vec<std::int64_t> ctrl_qpos, Vec<std::int64_t> touch_body, Vec<std::int64_t> touch_dest,
                     Vec<std::int64_t> light_body, Vec<std::int64_t> light_row, Vec<std::int64_t> light_dest,
                     Mat3 light_point, Mat3 light_facing, Vec<double> screen) {
    WorldStep w;
    w.m_ = reinterpret_cast<const mjModel*>(model);
    w.d_ = reinterpret_cast<mjData*>(data);
    if (w.m_ == nullptr || w.d_ == nullptr) throw nb::value_error("null MuJoCo model or data");
    const mjModel* m = w.m_;
    set_physics(w.s_, substeps, control_period, servo_k, max_velocity, gravity, imu_high, light, light_range,
                "bad world step settings");
    w.root_body_ = ints(root_body);
    w.root_qpos_ = ints(root_qpos);
    w.root_dof_ = ints(root_dof);
    w.n_ = static_cast<int>(w.root_body_.size());
    if (w.root_qpos_.size() != w.root_body_.size() || w.root_dof_.size() != w.root_body_.size()) {
        throw nb::value_error("root arrays differ in length");
    }
    check_index(w.root_body_, m->nbody, "root body");
    for (int r = 0; r < w.n_; ++r) {
        if (w.root_qpos_[r] < 0 || w.root_qpos_[r] + 7 > m->nq || w.root_dof_[r] < 0 || w.root_dof_[r] + 6 > m->nv) {
            throw nb::value_error("a robot's root is not in the model");
        }
    }
    w.hinge_qpos_ = ints(hinge_qpos);
    w.hinge_dof_ = ints(hinge_dof);
    w.J_ = static_cast<int>(w.hinge_qpos_.size());
    if (w.hinge_dof_.size() != w.hinge_qpos_.size()) throw nb::value_error("hinge addresses differ in length");
    check_index(w.hinge_qpos_, m->nq, "hinge qpos");
    check_index(w.hinge_dof_, m->nv, "hinge dof");
    w.joint_start_ = ints(joint_start);
    w.input_start_ = ints(input_start);
    if (static_cast<int>(w.joint_start_.size()) != w.n_ + 1 || w.joint_start_[0] != 0 ||
        w.joint_start_[w.n_] != w.J_ || static_cast<int>(w.input_start_.size()) != w.n_) {
        throw nb::value_error("bad robot offsets");
    }
    for (int r = 0; r < w.n_; ++r) {
        if (w.joint_start_[r + 1] < w.joint_start_[r] || w.input_start_[r] < 0 || w.input_start_[r] + 6 > n_inputs) {
            throw nb::value_error("bad robot offsets");
        }
    }
    w.n_inputs_ = n_inputs;
    w.ctrl_qpos_ = ints(ctrl_qpos);
    if (static_cast<int>(w.ctrl_qpos_.size()) != m->nu) throw nb::value_error("one actuator per active hinge expected");
    check_index(w.ctrl_qpos_, m->nq, "actuator qpos");
    w.touch_body_ = ints(touch_body);
    w.touch_dest_ = ints(touch_dest);
    check_index(w.touch_body_, m->nbody, "touch body");
    check_index(w.touch_dest_, n_inputs, "touch input");
    if (w.touch_body_.size() != w.touch_dest_.size()) throw nb::value_error("touch arrays differ in length");
    const std::size_t k = light_body.shape(0);
    if (light_row.shape(0) != k || light_dest.shape(0) != k || light_point.shape(0) != k ||
        light_facing.shape(0) != k) {
        throw nb::value_error("light arrays differ in length");
    }
    for (std::size_t i = 0; i < k; ++i) {
        Light L{static_cast<int>(light_body(i)), static_cast<int>(light_dest(i)), {}, {},
                static_cast<int>(light_row(i))};
        if (L.body < -1 || L.body >= m->nbody || L.dest < 0 || L.dest >= n_inputs || L.row < 0 || L.row >= w.n_) {
            throw nb::value_error("light sensor out of range");
        }
        for (int j = 0; j < 3; ++j) {
            L.point[j] = light_point(i, j);
            L.facing[j] = light_facing(i, j);
        }
        w.lights_.push_back(L);
    }
    if (screen.shape(0) != static_cast<std::size_t>(9 * w.n_ + 2 * w.J_)) throw nb::value_error("bad screen");
    w.screen_.assign(screen.data(), screen.data() + screen.shape(0));
    w.touched_.assign(m->nbody, 0);
    new (self) WorldStep(std::move(w));
}

int world_step(WorldStep& w, Vec<double> targets, Out start, Out states, Out sensors) {
    if (targets.shape(0) != static_cast<std::size_t>(w.m_->nu) ||
        start.shape(0) != static_cast<std::size_t>(w.state_size()) || states.shape(0) != w.states_size() ||
        sensors.shape(0) != static_cast<std::size_t>(w.n_inputs_)) {
        throw nb::value_error("world step arrays of the wrong size");
    }
    nb::gil_scoped_release release;
    return w.step(targets.data(), start.data(), states.data(), sensors.data());
}

nb::ndarray<nb::numpy, double> copy_array(const double* src, std::size_t n, std::vector<std::size_t> shape) {
    double* buf = new double[n];
    if (n) std::memcpy(buf, src, n * sizeof(double));
    nb::capsule owner(buf, [](void* p) noexcept { delete[] static_cast<double*>(p); });
    return nb::ndarray<nb::numpy, double>(buf, shape.size(), shape.data(), owner);
}

// ---- Locomotion's step: LocomotionEnv's one robot, one env step in one call ------------------------------
//
// EnvStep is one step of revolve_env.envs.locomotion.LocomotionEnv on MuJoCo: the action's check and clip
// to the world's targets (World._write_targets), or the robot's brain (revolve::BatchController, stepped
// every brain_stride periods on the previous observation's sensor values), the world's period (WorldStep),
// the task's fitness window of the robot (revolve_env.rollout.RobotWindow: poses at the task's stride,
// the same floating-point operations in the same order), the shipped tasks' fitness (tasks.Locomotion,
// DirectedLocomotion, LightFollowing: the Python rules are the reference, compared bit for bit by the
// tests), the reward (the fitness gain) and the observation (sensors, then the active hinges' angles and
// speeds, clipped to the observation's bounds). What is rare stays in Python: a bad action, a brain whose
// outputs are not finite, a period that is not calm or an observation that is not finite return early
// and the env finishes the step on its general path (with this window, see the window_* methods).

// CPython's math.hypot of two numbers (Modules/mathmodule.c: vector_norm, 3.10 and 3.11), which the
// fitness windows use; not the C library's hypot (they differ in the last bit now and then). Checked
// against math.hypot on random data at import (revolve_env.world.compiled).
double py_hypot(double a, double b) {
    double vec[2] = {std::fabs(a), std::fabs(b)};
    const bool found_nan = std::isnan(vec[0]) || std::isnan(vec[1]);
    double max = 0.0;
    for (double x : vec) {
        if (x > max) max = x;
    }
    if (std::isinf(max)) return max;
    if (found_nan) return NAN;
    if (max == 0.0) return max;
    int max_e;
    std::frexp(max, &max_e);
    double rescale = 1.0;
    if (max_e < -1023) {  // subnormals: to normals first
        for (double& x : vec) x /= DBL_MIN;
        rescale = DBL_MIN;
        max /= DBL_MIN;
        std::frexp(max, &max_e);
    }
    const double T27 = 134217729.0;
    double x, t, hi, lo, oldcsum, csum = 1.0, frac1 = 0.0, frac2 = 0.0, frac3 = 0.0;
    const double scale = std::ldexp(1.0, -max_e);
    for (double v : vec) {
        x = v * scale;
        t = x * T27;
        hi = t - (t - x);
        lo = x - hi;
        x = hi * hi;
        oldcsum = csum;
        csum += x;
        frac1 += (oldcsum - csum) + x;
        x = 2.0 * hi * lo;
        oldcsum = csum;
        csum += x;
        frac2 += (oldcsum - csum) + x;
        frac3 += lo * lo;
    }
    const double h = std::sqrt(csum - 1.0 + (frac1 + frac2 + frac3));
    x = h;
    t = x * T27;
    hi = t - (t - x);
    lo = x - hi;
    x = -hi * hi;
    oldcsum = csum;
    csum += x;
    frac1 += (oldcsum - csum) + x;
    x = -2.0 * hi * lo;
    oldcsum = csum;
    csum += x;
    frac2 += (oldcsum - csum) + x;
    x = -lo * lo;
    oldcsum = csum;
    csum += x;
    frac3 += (oldcsum - csum) + x;
    x = csum - 1.0 + (frac1 + frac2 + frac3);
    return rescale * ((h + x / (2.0 * h)) / scale);
}

// A shipped task's fitness of a window (tasks.Locomotion, DirectedLocomotion, LightFollowing).
struct TaskRule {
    enum Kind : int { kLocomotion = 0, kDirected = 1, kLight = 2 };
    int kind = kLocomotion;
    double s_weight = 0, limit = 0, cos_h = 1, sin_h = 0;
    bool has_limit = false;

    double fitness(double dx, double dy, double v, double s, double duration, double g0, double g1) const {
        if (kind == kDirected) return dx * cos_h + dy * sin_h;
        if (kind == kLight) return g1 - g0;
        double f = v + s_weight * s;  // fitness.terms.speed_fitness
        if (has_limit) {
            if (f >= limit * duration) f = 0.0;
            if (duration <= 0.0) f = 0.0;
        }
        return f;
    }

    // From revolve_env.rollout.task_rule's tuple (kind, s_weight, limit: NaN for none, cos_h, sin_h).
    static TaskRule from(int kind, double s_weight, double limit, double cos_h, double sin_h) {
        TaskRule r;
        r.kind = kind;
        r.s_weight = s_weight;
        r.has_limit = !std::isnan(limit);
        r.limit = limit;
        r.cos_h = cos_h;
        r.sin_h = sin_h;
        return r;
    }
};

// revolve_env.rollout.RobotWindow: one robot's window of pose samples, oldest first.
class EnvWindow {
   public:
    struct Sample {
        double t, x, y, path, signal;
    };
    enum Push : int { kPushed = 0, kBadTime = 1, kEarly = 2, kBadPosition = 3, kNoSignal = 4 };

    double window = 0;
    int insertion = 0, stride = 1;
    bool signal = false;
    std::deque<Sample> samples;

    bool holds(long age) const {
        const long since = age - insertion;
        return stride > 1 && since > 0 && since % stride != 0;
    }

    Sample last() const { return samples.empty() ? Sample{0, 0, 0, 0, 0} : samples.back(); }

    int push(double time, double x, double y, long age, bool has_signal, double sig) {
        if (holds(age)) {
            const Sample held = last();
            x = held.x;
            y = held.y;
            if (has_signal && signal) sig = held.signal;
        }
        if (!std::isfinite(time)) return kBadTime;
        if (!samples.empty() && time < samples.back().t) return kEarly;
        if (!(std::isfinite(x) && std::isfinite(y))) return kBadPosition;
        if (signal && !has_signal) return kNoSignal;
        double path = 0.0;
        if (!samples.empty()) {
            const Sample& p = samples.back();
            path = p.path + py_hypot(x - p.x, y - p.y);
            const double horizon = time - window - 1e-9;  // fitness.terms.TIME_EPS
            while (!samples.empty() && samples.front().t < horizon) samples.pop_front();
        }
        samples.push_back(Sample{time, x, y, path, signal && has_signal ? sig : 0.0});
        if (path > 1e3) {  // keep the running sum small so that differences stay exact
            const double base = samples.front().path;
            for (Sample& s : samples) s.path -= base;
        }
        return kPushed;
    }

    // (fitness, v, s) of the window now; zeros below two samples.
    void terms(const TaskRule& rule, double out[3]) const {
        if (samples.size() < 2) {
            out[0] = out[1] = out[2] = 0.0;
            return;
        }
        const Sample& a = samples.front();
        const Sample& b = samples.back();
        const double dx = b.x - a.x, dy = b.y - a.y;
        const double v = b.path - a.path;
        const double s = py_hypot(dx, dy);
        out[0] = rule.fitness(dx, dy, v, s, b.t - a.t, a.signal, b.signal);
        out[1] = v;
        out[2] = s;
    }
};

class EnvStep {
   public:
    // What step() did: all of it (kDone), or it stopped for Python: a bad action (nothing done), a brain
    // whose outputs are not finite (the brain stepped, nothing else), or the world's period outcome
    // (WorldStep::Outcome: the period done, the env's part left to Python).
    enum Code : int { kDone = 10, kBadAction = -1, kBrainDiverged = -2 };

    WorldStep* w = nullptr;
    bool brain_driven = false, proprioception = false;
    int n_act = 0, n_out = 0, n_in = 0, n_obs = 0, brain_stride = 1;
    double target_scale = 0;
    std::vector<int> active;         // index of each active hinge in the world's joint arrays
    std::vector<double> low, high;   // the observation's bounds
    std::vector<int> signal_inputs;  // the light signal: the robot's light sensors' inputs
    std::unique_ptr<revolve::BatchController> brain;
    std::vector<double> inputs;
    TaskRule rule;
    EnvWindow window;
    double terms[3] = {0, 0, 0};  // the task's fitness, v, s after the last step (metres)

    double light_signal(const double* sensors, const double* core) const {
        if (signal_inputs.empty()) return falloff_value(core, w->s_.light, w->s_.light_range);
        double best = sensors[signal_inputs[0]];
        for (std::size_t k = 1; k < signal_inputs.size(); ++k) best = np_max(best, sensors[signal_inputs[k]]);
        return best;
    }

    // One env step. action: n_act values (any; checked here); obs: the previous observation (the brain
    // reads its sensor part), overwritten by the new one when done; targets: the world's targets
    // (radians); outputs: the brain's outputs (held between its steps); start, states, sensors: as
    // WorldStep::step; out: reward, fitness, v, s, x, y. periods: control periods stepped before;
    // age: the env's step count after this step; time: the world's time after it (seconds).
    template <typename A>
    int step(const A* action, std::size_t n, double* obs, double* targets, double* outputs, double* start,
             double* states, double* sensors, double* out, long periods, long age, double time) {
        if (static_cast<int>(n) != n_act) return kBadAction;
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(static_cast<double>(action[i]))) return kBadAction;
        }
        const int nu = w->m_->nu;
        if (brain_driven) {  // the action is checked and ignored: the brain drives
            if (periods % brain_stride == 0) {
                std::memcpy(inputs.data(), obs, n_in * sizeof(double));
                brain->step(inputs.data(), outputs);
                if (!finite(outputs, n_out)) return kBrainDiverged;
            }
            for (int i = 0; i < nu; ++i) targets[i] = np_min(np_max(outputs[i], -1.0), 1.0) * target_scale;
        } else {  // LocomotionEnv._checked, then World._write_targets (the same clip again)
            for (int i = 0; i < nu; ++i) {
                const double a = np_min(np_max(static_cast<double>(action[i]), -1.0), 1.0);
                targets[i] = np_min(np_max(a, -1.0), 1.0) * target_scale;
            }
        }
        const int outcome = w->step(targets, start, states, sensors);
        if (outcome != WorldStep::kCalm) return outcome;
        const int n_rob = w->n_;
        const double* pos = states;
        const double* jpos = states + 18 * n_rob;
        const double* jvel = jpos + w->J_;
        // LocomotionEnv._get_obs: finite, then clipped to the bounds (else Python's rules)
        double* o = obs;
        bool ok = true;
        for (int i = 0; i < n_in; ++i) ok &= std::isfinite(sensors[i]);
        if (proprioception) {
            for (int i : active) ok &= std::isfinite(jpos[i]) && std::isfinite(jvel[i]);
        }
        if (!ok) return outcome;
        // LocomotionEnv._sample and _get_reward
        const double previous = terms[0];
        if (age >= window.insertion) {
            double sig = 0.0;
            if (window.signal) sig = window.holds(age) ? 0.0 : light_signal(sensors, pos);
            if (window.push(time, pos[0], pos[1], age, window.signal, sig) != EnvWindow::kPushed) return outcome;
            window.terms(rule, terms);
        }
        out[0] = terms[0] - previous;
        out[1] = terms[0];
        out[2] = terms[1];
        out[3] = terms[2];
        out[4] = pos[0];
        out[5] = pos[1];
        int k = 0;
        for (int i = 0; i < n_in; ++i, ++k) o[k] = np_min(np_max(sensors[i], low[k]), high[k]);
        if (proprioception) {
            for (int i : active) {
                o[k] = np_min(np_max(jpos[i], low[k]), high[k]);
                ++k;
            }
            for (int i : active) {
                o[k] = np_min(np_max(jvel[i], low[k]), high[k]);
                ++k;
            }
        }
        return kDone;
    }
};

using Obs = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

// EnvStep with the arrays it keeps between steps (held, so they stay valid): the world's targets, the
// brain's outputs, the backend's start state and the step's outputs (reward, fitness, v, s, x, y); and
// the WorldStep it steps (w), held by a reference that set_world replaces: only the live one is kept
// alive (a keep_alive would keep every world it ever stepped for as long as it lives).
struct BoundEnvStep : EnvStep {
    Out targets, outputs, start, out;
    nb::object world;

    void check() const {
        if (targets.shape(0) != static_cast<std::size_t>(w->m_->nu) ||
            (brain_driven && outputs.shape(0) != static_cast<std::size_t>(n_out)) ||
            start.shape(0) != static_cast<std::size_t>(w->state_size()) || out.shape(0) != 6) {
            throw nb::value_error("env step arrays of the wrong size");
        }
    }
};

void make_env_step(BoundEnvStep* self, nb::handle world_step, Out targets, Out outputs, Out start, Out out, int n_act,
                   int n_inputs, Vec<std::int64_t> active,
                   bool proprioception, Vec<double> low, Vec<double> high, double target_scale, int task_kind,
                   double s_weight, double limit, double cos_h, double sin_h, double window, int insertion,
                   int stride, Vec<std::int64_t> signal_inputs, nb::object network, double brain_dt, int brain_stride) {
    WorldStep& world = nb::cast<WorldStep&>(world_step);
    BoundEnvStep e;
    e.w = &world;
    e.world = nb::borrow(world_step);
    e.targets = targets;
    e.outputs = outputs;
    e.start = start;
    e.out = out;
    e.n_act = n_act;
    e.n_out = world.m_->nu;
    e.n_in = n_inputs;
    e.active = ints(active);
    check_index(e.active, world.J_, "active hinge");
    e.proprioception = proprioception;
    e.n_obs = n_inputs + (proprioception ? 2 * static_cast<int>(e.active.size()) : 0);
    if (world.n_ != 1 || n_inputs != world.n_inputs_ || static_cast<int>(e.active.size()) != e.n_out ||
        low.shape(0) != static_cast<std::size_t>(e.n_obs) || high.shape(0) != low.shape(0) || task_kind < 0 ||
        task_kind > 2 || window <= 0 || insertion < 0 || stride < 1 || brain_stride < 1) {
        throw nb::value_error("bad env step settings");
    }
    e.low.assign(low.data(), low.data() + low.shape(0));
    e.high.assign(high.data(), high.data() + high.shape(0));
    e.target_scale = target_scale;
    e.rule = TaskRule::from(task_kind, s_weight, limit, cos_h, sin_h);
    e.window.window = window;
    e.window.insertion = insertion;
    e.window.stride = stride;
    e.window.signal = task_kind == TaskRule::kLight;
    e.signal_inputs = ints(signal_inputs);
    check_index(e.signal_inputs, n_inputs, "light input");
    e.brain_stride = brain_stride;
    if (!network.is_none()) {  // (kinds, params, src, dst, weight, n_inputs, n_outputs) of as_spec
        auto kinds = nb::cast<Vec<std::int8_t>>(network[0]);
        auto params = nb::cast<nb::ndarray<const double, nb::ndim<2>, nb::c_contig>>(network[1]);
        auto src = nb::cast<Vec<std::int32_t>>(network[2]);
        auto dst = nb::cast<Vec<std::int32_t>>(network[3]);
        auto weight = nb::cast<Vec<double>>(network[4]);
        const auto net_in = nb::cast<std::int64_t>(network[5]);
        const auto net_out = nb::cast<std::int64_t>(network[6]);
        if (net_in != n_inputs || net_out != e.n_out) throw nb::value_error("the network does not fit the body");
        e.brain = std::make_unique<revolve::BatchController>(brain_dt);
        e.brain->add(network_view(kinds, params, src, dst, weight, net_in, net_out));
        e.brain_driven = true;
        e.inputs.assign(n_inputs, 0.0);
    }
    e.check();
    new (self) BoundEnvStep(std::move(e));
}

template <typename A>
int env_step(BoundEnvStep& e, nb::ndarray<const A, nb::ndim<1>, nb::c_contig, nb::device::cpu> action, Obs obs,
             Out states, Out sensors, long periods, long age, double time) {
    const WorldStep& w = *e.w;
    if (obs.shape(0) != static_cast<std::size_t>(e.n_obs) || states.shape(0) != w.states_size() ||
        sensors.shape(0) != static_cast<std::size_t>(w.n_inputs_)) {
        throw nb::value_error("env step arrays of the wrong size");
    }
    nb::gil_scoped_release release;
    return e.step(action.data(), action.shape(0), obs.data(), e.targets.data(), e.outputs.data(), e.start.data(),
                  states.data(), sensors.data(), e.out.data(), periods, age, time);
}

// ---- The rules over a World's arrays (pybullet) ---------------------------------------------------
//
// pybullet's World keeps its engine calls in Python (one set of motors, stepSimulation, the body
// reads, the contact list and the link poses) but takes the rules of a control period from here,
// over the arrays that its NumPy path would give to NumPy: the target clipping, RoboGen's servo
// law, the blow-up screen, the IMU and the light sensors (revolve_env.world.compiled.Rules). The
// same functions as Rollout's and WorldStep's, so the same bits. The GIL is kept: each call is a
// few microseconds of work at most for the worlds the envs step, less than handing the GIL over
// and waiting to get it back from another thread would cost.

using Flags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Rot3 = nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu>;
using Column3 = nb::ndarray<const double, nb::shape<-1, 3, 1>, nb::c_contig, nb::device::cpu>;

// World._write_targets for every target: clipped to [-1, 1] and scaled into out (radians); false,
// and nothing written, when a target is not finite (the NumPy path flags its robot).
bool clip_targets(Vec<double> targets, double scale, Out out) {
    const std::size_t n = targets.shape(0);
    if (out.shape(0) != n) throw nb::value_error("targets and out differ in length");
    if (!finite(targets.data(), static_cast<int>(n))) return false;
    const double* t = targets.data();
    double* o = out.data();
    for (std::size_t i = 0; i < n; ++i) o[i] = np_min(np_max(t[i], -1.0), 1.0) * scale;
    return true;
}

// World.step's servo law: the commanded velocity of every active hinge (rad/s), the hinge angles
// read from joint_pos at active.
nb::ndarray<nb::numpy, double> servo_velocities(Vec<double> targets, Vec<double> joint_pos,
                                                Vec<std::int64_t> active, double servo_k, double max_velocity) {
    const std::size_t n = targets.shape(0);
    const auto J = static_cast<std::int64_t>(joint_pos.shape(0));
    if (active.shape(0) != n) throw nb::value_error("targets and active hinges differ in length");
    std::vector<double> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::int64_t j = active(i);
        if (j < 0 || j >= J) throw nb::value_error("active hinge out of range");
        out[i] = servo_velocity(servo_k, targets(i), joint_pos(j), max_velocity);
    }
    return copy_array(out.data(), n, {n});
}

// blowups.all_calm over every robot's BodyStates row (the screen of Screen(n, J).inverse).
bool all_calm_rows(Mat3 pos, Rot3 rot, Mat3 vel, Mat3 spin, Vec<double> joint_pos, Vec<double> joint_vel,
                   Flags diverged, Vec<std::int64_t> joint_offsets, Vec<double> screen) {
    const std::size_t n = pos.shape(0);
    const std::size_t J = joint_pos.shape(0);
    if (rot.shape(0) != n || vel.shape(0) != n || spin.shape(0) != n || diverged.shape(0) != n ||
        joint_vel.shape(0) != J || joint_offsets.shape(0) != n + 1 || screen.shape(0) != 9 * n + 2 * J) {
        throw nb::value_error("states, offsets and screen do not fit");
    }
    const std::int64_t* off = joint_offsets.data();
    if (off[0] != 0 || off[n] != static_cast<std::int64_t>(J)) throw nb::value_error("bad joint offsets");
    for (std::size_t r = 0; r < n; ++r) {
        if (off[r + 1] < off[r]) throw nb::value_error("bad joint offsets");
    }
    const double* sc = screen.data();
    const double* jp = joint_pos.data();
    const double* jv = joint_vel.data();
    bool ok = finite(rot.data(), static_cast<int>(9 * n));
    for (std::size_t r = 0; r < n && ok; ++r) {
        const std::size_t j0 = static_cast<std::size_t>(off[r]);
        const int Jr = static_cast<int>(off[r + 1] - off[r]);
        const ScreenView view{sc + 3 * r, sc + 3 * n + 3 * r, sc + 6 * n + j0, sc + 6 * n + J + 3 * r,
                              sc + 9 * n + J + j0};
        ok = !diverged(r) && calm_entries(
                                 pos.data() + 3 * r, vel.data() + 3 * r, spin.data() + 3 * r, Jr,
                                 [&](int i) { return jp[j0 + i]; }, [&](int i) { return jv[j0 + i]; }, view);
    }
    return ok;
}

// World._sense without the touch sensors: every robot's saturated IMU at the start of its part of
// out (input_offsets), then every light sensor's value at light_dest: the first root_rows.size()
// on cores (they read their core's pose), the others on links (link_pos, link_rot, the poses the
// backend read).
void sense_rows(Out out, Vec<std::int64_t> input_offsets, Mat3 pos, Rot3 rot, Mat3 vel, Mat3 prev, Mat3 spin,
                double control_period, double gravity, Vec<double> imu_high, Vec<std::int64_t> light_dest,
                Vec<std::int64_t> root_rows, Mat3 link_pos, Rot3 link_rot, Column3 points, Column3 facings,
                Vec<double> light, double light_range) {
    const std::size_t n = pos.shape(0);
    const std::size_t m = out.shape(0);
    const std::size_t roots = root_rows.shape(0);
    const std::size_t k = light_dest.shape(0);
    if (rot.shape(0) != n || vel.shape(0) != n || prev.shape(0) != n || spin.shape(0) != n ||
        input_offsets.shape(0) != n + 1 || imu_high.shape(0) != 6 || light.shape(0) != 3 ||
        link_pos.shape(0) != k - roots || link_rot.shape(0) != k - roots || points.shape(0) != k ||
        facings.shape(0) != k || roots > k) {
        throw nb::value_error("sensor arrays do not fit");
    }
    Settings s;
    s.inv_period = 1.0 / control_period;  // as imu_readings computes it
    s.gravity = gravity;
    for (int i = 0; i < 6; ++i) s.imu_high[i] = imu_high(i);
    for (int i = 0; i < 3; ++i) s.light[i] = light(i);
    s.light_range = light_range;
    double* o = out.data();
    for (std::size_t r = 0; r < n; ++r) {
        const std::int64_t at = input_offsets(r);
        if (at < 0 || static_cast<std::size_t>(at) + 6 > m) throw nb::value_error("input offset out of range");
        imu_reading(rot.data() + 9 * r, vel.data() + 3 * r, spin.data() + 3 * r, prev.data() + 3 * r, s, o + at);
    }
    for (std::size_t i = 0; i < k; ++i) {
        const std::int64_t at = light_dest(i);
        if (at < 0 || static_cast<std::size_t>(at) >= m) throw nb::value_error("light input out of range");
        const double *where, *R;
        if (i < roots) {
            const std::int64_t r = root_rows(i);
            if (r < 0 || static_cast<std::size_t>(r) >= n) throw nb::value_error("light row out of range");
            where = pos.data() + 3 * r;
            R = rot.data() + 9 * r;
        } else {
            where = link_pos.data() + 3 * (i - roots);
            R = link_rot.data() + 9 * (i - roots);
        }
        o[at] = light_value(where, R, points.data() + 3 * i, facings.data() + 3 * i, s.light, s.light_range);
    }
}

void bind_array_rules(nb::module_& mod) {
    mod.def("clip_targets", &clip_targets, nb::arg("targets"), nb::arg("scale"), nb::arg("out").noconvert(),
            "World._write_targets into out; False (nothing written) if a target is not finite.");
    mod.def("servo_velocities", &servo_velocities, nb::arg("targets"), nb::arg("joint_pos"), nb::arg("active"),
            nb::arg("servo_k"), nb::arg("max_velocity"), "RoboGen's servo law of every active hinge. Rad/s.");
    mod.def("all_calm_rows", &all_calm_rows, nb::arg("pos"), nb::arg("rot"), nb::arg("vel"), nb::arg("spin"),
            nb::arg("joint_pos"), nb::arg("joint_vel"), nb::arg("diverged"), nb::arg("joint_offsets"),
            nb::arg("screen"), "blowups.all_calm over BodyStates' arrays.");
    mod.def("sense_rows", &sense_rows, nb::arg("out").noconvert(), nb::arg("input_offsets"), nb::arg("pos"), nb::arg("rot"),
            nb::arg("vel"), nb::arg("prev"), nb::arg("spin"), nb::arg("control_period"), nb::arg("gravity"),
            nb::arg("imu_high"), nb::arg("light_dest"), nb::arg("root_rows"), nb::arg("link_pos"),
            nb::arg("link_rot"), nb::arg("points"), nb::arg("facings"), nb::arg("light"), nb::arg("light_range"),
            "World._sense's IMU and light sensor values into out.");
}

}  // namespace

// The population env's fitness windows, one push per control period (revolve_env.rollout.TaskWindows
// .push on a revolve_env.fitness.FitnessWindows without a signal, then FitnessWindows.current), in
// place on the ring's own arrays. The same operations in the same order as the NumPy code; math.hypot
// is CPython's (py_hypot above, the env step's; checked against math.hypot at import). What the NumPy code does rarely it is left to do: windows_push declines (returns false,
// nothing changed) a push at the latest sample time again (a birth between two steps), a ring that
// must grow, a path past 1 km (rebased), and a time before the last one or a non-finite position of a
// robot that samples (errors there).
namespace windows {

constexpr std::int64_t kNone = INT64_MAX;  // FitnessWindows._NONE: no sample yet

using I64 = nb::ndarray<std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Ring = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

// One push and every robot's window after it (see above). `sampling`: which robots sample (empty:
// all); ring_t (cap,), ring_xy (cap, n, 2), ring_path (cap, n), first/last (n,) and seq/start are
// FitnessWindows' own. Out: the window's first and last (x, y) (n, 2), v, s, samples and duration.
// Returns (pushed, seq, start, all_started).
// The ring of FitnessWindows (its own arrays) and the window written after a push, as raw pointers
// (push's, and the population's periods' below): ring_t (cap,), ring_xy (cap, n, 2), ring_path (cap, n),
// first/last (n,); the window's first and last (x, y) (n, 2), v, s, samples and duration (n,).
struct RingView {
    std::size_t n = 0;
    std::int64_t cap = 0;
    double *rt = nullptr, *rxy = nullptr, *rpath = nullptr;
    std::int64_t *fst = nullptr, *lst = nullptr;
    double *wf = nullptr, *wl = nullptr, *wv = nullptr, *ws = nullptr, *wdur = nullptr;
    std::int64_t* wcount = nullptr;
};

struct Pushed {
    bool pushed;
    std::int64_t seq, start;
    bool all_started;
};

// The push itself (no Python): `samp` null means every robot samples; xs, ys, paths are scratch (n).
Pushed push_raw(double t, double window, double eps, std::int64_t stride, std::int64_t insertion, const double* pos,
                const std::int64_t* age, const bool* samp, const RingView& ring, std::int64_t seq, std::int64_t start,
                std::vector<double>& xs, std::vector<double>& ys, std::vector<double>& paths) {
    const std::size_t n = ring.n;
    const std::int64_t cap = ring.cap;
    const Pushed declined{false, seq, start, false};
    double* rt = ring.rt;
    double* rxy = ring.rxy;
    double* rpath = ring.rpath;
    std::int64_t* fst = ring.fst;
    std::int64_t* lst = ring.lst;
    const auto wrap = [cap](std::int64_t s) { return ((s % cap) + cap) % cap; };
    if (seq > start && t < rt[wrap(seq - 1)]) return declined;  // an error: Python says which
    if (!std::isfinite(t)) return declined;
    // The latest sample time again (a robot joining it): Python's.
    if (seq > start && t == rt[wrap(seq - 1)]) {
        bool sampled_then = false;
        for (std::size_t i = 0; i < n; ++i) {
            if ((samp == nullptr || samp[i]) && lst[i] == seq - 1) sampled_then = true;
        }
        if (!sampled_then) return declined;
    }
    // Each sampling robot's (x, y) now (a held pose between pose samples) and its path.
    xs.resize(n);
    ys.resize(n);
    paths.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        if (samp != nullptr && !samp[i]) continue;
        double x = pos[3 * i], y = pos[3 * i + 1];
        const std::int64_t lo = std::max(fst[i], start);
        const bool some = lst[i] - lo + 1 > 0;
        if (stride > 1) {
            const std::int64_t since = age[i] - insertion;
            const bool posing = since >= 0 && since % stride == 0;
            if (!posing && since > 0) {  // it holds its last pose (zeros with none)
                const std::int64_t row = some ? wrap(lst[i]) : 0;
                x = some ? rxy[(row * n + i) * 2] : 0.0;
                y = some ? rxy[(row * n + i) * 2 + 1] : 0.0;
            }
        }
        if (!std::isfinite(x) || !std::isfinite(y)) return declined;
        double path = 0.0;
        if (fst[i] != kNone) {
            const std::int64_t prev = wrap(lst[i]);
            path = rpath[prev * n + i] + py_hypot(x - rxy[(prev * n + i) * 2], y - rxy[(prev * n + i) * 2 + 1]);
        }
        if (path > 1e3) return declined;  // rebased by Python
        xs[i] = x;
        ys[i] = y;
        paths[i] = path;
    }
    // Sample times that left the window go (the newest one stays).
    const double horizon = t - window - eps;
    while (start < seq && rt[wrap(start)] < horizon) ++start;
    if (seq - start == cap) return declined;  // the ring grows (Python)
    const std::int64_t row = wrap(seq);
    rt[row] = t;
    bool all_started = true;
    for (std::size_t i = 0; i < n; ++i) {
        if (samp == nullptr || samp[i]) {
            rxy[(row * n + i) * 2] = xs[i];
            rxy[(row * n + i) * 2 + 1] = ys[i];
            rpath[row * n + i] = paths[i];
            if (fst[i] == kNone) fst[i] = seq;
            lst[i] = seq;
        }
        all_started = all_started && fst[i] != kNone;
    }
    ++seq;
    // Every robot's window now (FitnessWindows.current).
    double* wf = ring.wf;
    double* wl = ring.wl;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int64_t lo = std::max(fst[i], start);
        const std::int64_t count = std::max<std::int64_t>(lst[i] - lo + 1, 0);
        const bool some = count > 0;
        const std::int64_t fc = some ? wrap(lo) : 0, lc = some ? wrap(lst[i]) : 0;
        ring.wcount[i] = count;
        if (count < 2) {
            wf[2 * i] = wf[2 * i + 1] = wl[2 * i] = wl[2 * i + 1] = 0.0;
            ring.wv[i] = ring.ws[i] = ring.wdur[i] = 0.0;
            continue;
        }
        const double* a = rxy + (fc * n + i) * 2;
        const double* b = rxy + (lc * n + i) * 2;
        wf[2 * i] = a[0];
        wf[2 * i + 1] = a[1];
        wl[2 * i] = b[0];
        wl[2 * i + 1] = b[1];
        ring.wv[i] = rpath[lc * n + i] - rpath[fc * n + i];
        ring.ws[i] = py_hypot(b[0] - a[0], b[1] - a[1]);
        ring.wdur[i] = rt[lc] - rt[fc];
    }
    return Pushed{true, seq, start, all_started};
}

nb::tuple push(double t, double window, double eps, std::int64_t stride, std::int64_t insertion,
               Vec<double> position, nb::ndarray<const std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu> ages,
               Flags sampling, Ring ring_t, Ring ring_xy, Ring ring_path, I64 first, I64 last, std::int64_t seq,
               std::int64_t start, Out w_first, Out w_last, Out w_v, Out w_s, I64 w_count, Out w_duration) {
    const std::size_t n = ages.shape(0);
    const std::int64_t cap = static_cast<std::int64_t>(ring_t.shape(0));
    if (position.shape(0) != 3 * n || (sampling.shape(0) != 0 && sampling.shape(0) != n) ||
        ring_xy.size() != static_cast<std::size_t>(cap) * n * 2 || ring_path.size() != static_cast<std::size_t>(cap) * n ||
        first.shape(0) != n || last.shape(0) != n || w_first.shape(0) != 2 * n || w_last.shape(0) != 2 * n ||
        w_v.shape(0) != n || w_s.shape(0) != n || w_count.shape(0) != n || w_duration.shape(0) != n || cap < 2) {
        throw nb::value_error("window arrays of the wrong size");
    }
    const RingView ring{n,           cap,          ring_t.data(), ring_xy.data(), ring_path.data(),
                        first.data(), last.data(), w_first.data(), w_last.data(),  w_v.data(),
                        w_s.data(),  w_duration.data(), w_count.data()};
    std::vector<double> xs, ys, paths;
    const Pushed p = push_raw(t, window, eps, stride, insertion, position.data(), ages.data(),
                              sampling.shape(0) ? sampling.data() : nullptr, ring, seq, start, xs, ys, paths);
    return nb::make_tuple(p.pushed, p.seq, p.start, p.all_started);
}

}  // namespace windows

// ---- The population env's periods: many control periods of brain-driven robots in one call -------------
//
// PopulationPeriods is what PopulationEnv.advance({}) does, period after period, on a MuJoCo world whose
// robots are all brain-driven when nothing in between needs Python (no learner, no noise, no lifecycle, no
// trajectories, a shipped task without a signal): the brains step on the sensor values of the period before
// (a copy of the env's BatchController: the same networks in the same order, their states and times handed
// over before and back after, revolve::BatchController::set_state), their outputs clipped and scaled into
// the world's targets (World._write_targets), the world's period (WorldStep::step), the robots' ages, the
// fitness windows' push (windows::push_raw) and the task's fitness of every window (TaskRule, as
// tasks.score). The same operations in the same order as the Python path, so the same bits (the tests
// compare the two). It stops where Python has a part in a period: a brain whose outputs are not finite (the
// brain stepped, nothing else), a period that is not calm (the world stepped: WorldStep's outcome), a push
// that windows::push_raw declines (the world stepped, calm). The periods' states and sensors go to two
// buffers in turn, so that the last whole period's stay whole beside the one Python finishes. Python's signal
// handlers (Ctrl-C) run every kSignalEvery periods and after the last one: a handler that raises stops the run
// at a period's start, its error kept until Python has taken the whole periods back (raise_pending).
using windows::Pushed;
using windows::push_raw;
using windows::RingView;

class PopulationPeriods {
   public:
    enum Stop : int { kAll = 0, kBrain = 1, kWorld = 2 };
    static constexpr int kSignalEvery = 30;  // periods between two looks at Python's signals

    struct Result {
        int done = 0, stop = kAll, outcome = 0;
        std::int64_t seq = 0, start = 0;
        bool all_started = false, pushed = false;
        double time = 0;
    };

    WorldStep* w = nullptr;
    std::unique_ptr<revolve::BatchController> brain;
    double dt = 0, target_scale = 0, window = 0, eps = 0;
    std::int64_t stride = 1, insertion = 0, sample_from = 0;
    TaskRule rule;
    std::vector<double> xs, ys, paths;  // push_raw's scratch
    std::unique_ptr<bool[]> sampling;
    std::optional<nb::python_error> pending;  // a signal handler's error, raised by raise_pending

    // Runs Python's signal handlers (the GIL taken); false, the error kept in `pending`, if one raised.
    bool signals_clear() {
        nb::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() == 0) return true;
        pending.emplace();  // fetches the error and clears it
        return false;
    }

    // n periods at most. steps: the env's control periods before; time: the world's clock (seconds);
    // obs: the sensor values the brains read first; states/sensors: the two buffers; ages, ring, f, v, s:
    // the env's (written in place).
    Result run(int n, std::int64_t steps, double time, double* targets, double* outputs, const double* obs,
               double* start_state, double* const states[2], double* const sensors[2], std::int64_t* ages,
               const RingView& ring, std::int64_t seq, std::int64_t start, double* f, double* v, double* s) {
        Result res;
        res.seq = seq;
        res.start = start;
        const int nu = w->m_->nu;
        const std::size_t rows = ring.n;
        for (int i = 0; i < n; ++i) {
            res.done = i;
            res.time = time;
            if (i > 0 && i % kSignalEvery == 0 && !signals_clear()) return res;  // stop: kAll, i periods
            brain->step(i == 0 ? obs : sensors[(i - 1) % 2], outputs);  // Rollout.think
            if (!finite(outputs, nu)) {
                res.stop = kBrain;
                return res;
            }
            for (int k = 0; k < nu; ++k) targets[k] = np_min(np_max(outputs[k], -1.0), 1.0) * target_scale;
            double* st = states[i % 2];
            const int outcome = w->step(targets, start_state, st, sensors[i % 2]);
            if (outcome != WorldStep::kCalm) {
                res.stop = kWorld;
                res.outcome = outcome;
                return res;
            }
            // Living.sense: ages, then the windows of the robots past their insertion (core_pos: st's first 3n)
            bool any = false;
            for (std::size_t r = 0; r < rows; ++r) {
                ages[r] += 1;
                sampling[r] = ages[r] >= sample_from;
                any = any || sampling[r];
            }
            if (any) {
                const double t = static_cast<double>(steps + i + 1) * dt;  // Roster.time
                const Pushed p = push_raw(t, window, eps, stride, insertion, st, ages, sampling.get(), ring, res.seq,
                                          res.start, xs, ys, paths);
                if (!p.pushed) {  // Python's push: this period's sensing is left to it
                    for (std::size_t r = 0; r < rows; ++r) ages[r] -= 1;
                    res.stop = kWorld;
                    res.outcome = WorldStep::kCalm;
                    return res;
                }
                res.seq = p.seq;
                res.start = p.start;
                res.all_started = p.all_started;
                res.pushed = true;
                for (std::size_t r = 0; r < rows; ++r) {  // tasks.score: 0 below two samples
                    v[r] = ring.wv[r];
                    s[r] = ring.ws[r];
                    f[r] = ring.wcount[r] < 2 ? 0.0
                                              : rule.fitness(ring.wl[2 * r] - ring.wf[2 * r],
                                                             ring.wl[2 * r + 1] - ring.wf[2 * r + 1], ring.wv[r],
                                                             ring.ws[r], ring.wdur[r], 0.0, 0.0);
                }
            }
            time += dt;  // World.compiled_stepped
        }
        res.done = n;
        res.time = time;
        signals_clear();  // the last periods' signals too: raised after Python took them back
        return res;
    }
};

void make_population_periods(PopulationPeriods* self, WorldStep& world, double brain_dt, double target_scale,
                             double control_period, int task_kind, double s_weight, double limit, double cos_h,
                             double sin_h, double window, double eps, std::int64_t stride, std::int64_t insertion,
                             std::int64_t sample_from) {
    if (task_kind < 0 || task_kind > 1 || !(window > 0) || stride < 1 || insertion < 0 || !(control_period > 0)) {
        throw nb::value_error("bad population periods settings");
    }
    PopulationPeriods p;
    p.w = &world;
    p.brain = std::make_unique<revolve::BatchController>(brain_dt);
    p.dt = control_period;
    p.target_scale = target_scale;
    p.window = window;
    p.eps = eps;
    p.stride = stride;
    p.insertion = insertion;
    p.sample_from = sample_from;
    p.rule = TaskRule::from(task_kind, s_weight, limit, cos_h, sin_h);
    p.sampling.reset(new bool[static_cast<std::size_t>(world.n_)]());
    new (self) PopulationPeriods(std::move(p));
}

using Ages = nb::ndarray<std::int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

nb::tuple population_run(PopulationPeriods& p, int n, std::int64_t steps, double time, Out targets, Out outputs,
                         Vec<double> obs, Out start, Out states_a, Out sensors_a, Out states_b, Out sensors_b,
                         Ages ages, windows::Ring ring_t, windows::Ring ring_xy, windows::Ring ring_path,
                         windows::I64 first, windows::I64 last, std::int64_t seq, std::int64_t seq_start, Out f, Out v,
                         Out s, Out w_first, Out w_last, Out w_v, Out w_s, windows::I64 w_count, Out w_duration) {
    const WorldStep& w = *p.w;
    const std::size_t rows = static_cast<std::size_t>(w.n_);
    const std::int64_t cap = static_cast<std::int64_t>(ring_t.shape(0));
    const std::size_t nu = static_cast<std::size_t>(w.m_->nu);
    if (n < 0 || targets.shape(0) != nu || outputs.shape(0) != nu ||
        p.brain->n_outputs() != static_cast<std::int64_t>(nu) || p.brain->n_inputs() != w.n_inputs_ ||
        obs.shape(0) != static_cast<std::size_t>(w.n_inputs_) ||
        start.shape(0) != static_cast<std::size_t>(w.state_size()) || states_a.shape(0) != w.states_size() ||
        states_b.shape(0) != w.states_size() || sensors_a.shape(0) != static_cast<std::size_t>(w.n_inputs_) ||
        sensors_b.shape(0) != static_cast<std::size_t>(w.n_inputs_) || ages.shape(0) != rows || cap < 2 ||
        ring_xy.size() != static_cast<std::size_t>(cap) * rows * 2 ||
        ring_path.size() != static_cast<std::size_t>(cap) * rows || first.shape(0) != rows ||
        last.shape(0) != rows || f.shape(0) != rows || v.shape(0) != rows || s.shape(0) != rows ||
        w_first.shape(0) != 2 * rows || w_last.shape(0) != 2 * rows || w_v.shape(0) != rows ||
        w_s.shape(0) != rows || w_count.shape(0) != rows || w_duration.shape(0) != rows) {
        throw nb::value_error("population periods arrays of the wrong size");
    }
    const RingView ring{rows,         cap,         ring_t.data(),  ring_xy.data(), ring_path.data(),
                        first.data(), last.data(), w_first.data(), w_last.data(),  w_v.data(),
                        w_s.data(),   w_duration.data(), w_count.data()};
    double* const states[2] = {states_a.data(), states_b.data()};
    double* const sensors[2] = {sensors_a.data(), sensors_b.data()};
    PopulationPeriods::Result r;
    {
        nb::gil_scoped_release release;
        r = p.run(n, steps, time, targets.data(), outputs.data(), obs.data(), start.data(), states, sensors,
                  ages.data(), ring, seq, seq_start, f.data(), v.data(), s.data());
    }
    return nb::make_tuple(r.done, r.stop, r.outcome, r.seq, r.start, r.all_started, r.pushed, r.time);
}

void bind_population_periods(nb::module_& mod) {
    nb::class_<PopulationPeriods>(mod, "PopulationPeriods",
                                  "Control periods of a population of brain-driven robots on a WorldStep, in C++.")
        .def("__init__", &make_population_periods, nb::keep_alive<1, 2>(), nb::arg("world"), nb::arg("brain_dt"),
             nb::arg("target_scale"), nb::arg("control_period"), nb::arg("task_kind"), nb::arg("s_weight"),
             nb::arg("limit"), nb::arg("cos_h"), nb::arg("sin_h"), nb::arg("window"), nb::arg("eps"),
             nb::arg("stride"), nb::arg("insertion"), nb::arg("sample_from"))
        .def(
            "add_network",
            [](PopulationPeriods& p, Vec<std::int8_t> kinds, nb::ndarray<const double, nb::ndim<2>, nb::c_contig> params,
               Vec<std::int32_t> src, Vec<std::int32_t> dst, Vec<double> weight, std::int64_t n_inputs,
               std::int64_t n_outputs, Vec<double> state, double time) {
                const std::int64_t h = p.brain->add(network_view(kinds, params, src, dst, weight, n_inputs, n_outputs));
                p.brain->set_state(h, state.data(), static_cast<std::int64_t>(state.shape(0)), time);
                return h;
            },
            nb::arg("kinds"), nb::arg("params"), nb::arg("src"), nb::arg("dst"), nb::arg("weight"),
            nb::arg("n_inputs"), nb::arg("n_outputs"), nb::arg("state"), nb::arg("time"),
            "Add the next network (in the env controller's order) with its state and time; its handle.")
        .def(
            "state",
            [](PopulationPeriods& p, std::int64_t h) {
                const std::vector<double> x = p.brain->state(h);
                return copy_array(x.data(), x.size(), {x.size()});
            },
            nb::arg("handle"), "A network's neuron values now (spec order).")
        .def("time", [](PopulationPeriods& p, std::int64_t h) { return p.brain->time(h); }, nb::arg("handle"),
             "A network's time now (seconds).")
        .def(
            "raise_pending",
            [](PopulationPeriods& p) {
                if (!p.pending) return;
                nb::python_error error = std::move(*p.pending);
                p.pending.reset();
                throw error;
            },
            "Raise the error a signal handler raised during run (after the periods are taken back); else nothing.")
        .def("run", &population_run, nb::arg("n"), nb::arg("steps"), nb::arg("time"), nb::arg("targets").noconvert(),
             nb::arg("outputs").noconvert(), nb::arg("obs"), nb::arg("start").noconvert(),
             nb::arg("states_a").noconvert(), nb::arg("sensors_a").noconvert(), nb::arg("states_b").noconvert(),
             nb::arg("sensors_b").noconvert(), nb::arg("ages").noconvert(), nb::arg("ring_t").noconvert(),
             nb::arg("ring_xy").noconvert(), nb::arg("ring_path").noconvert(), nb::arg("first").noconvert(),
             nb::arg("last").noconvert(), nb::arg("seq"), nb::arg("seq_start"), nb::arg("f").noconvert(),
             nb::arg("v").noconvert(), nb::arg("s").noconvert(), nb::arg("w_first").noconvert(),
             nb::arg("w_last").noconvert(), nb::arg("w_v").noconvert(), nb::arg("w_s").noconvert(),
             nb::arg("w_count").noconvert(), nb::arg("w_duration").noconvert(),
             "Up to n periods (GIL released): (done, stop, outcome, seq, start, all_started, pushed, time).");
    mod.attr("PERIODS_ALL") = static_cast<int>(PopulationPeriods::kAll);
    mod.attr("PERIODS_BRAIN") = static_cast<int>(PopulationPeriods::kBrain);
    mod.attr("PERIODS_WORLD") = static_cast<int>(PopulationPeriods::kWorld);
}

NB_MODULE(_rollout, mod) {
    mod.doc() = "revolve-env's compiled rollout on MuJoCo (use revolve_env.world.compiled)";
    mod.attr("MUJOCO_HEADER") = mjVERSION_HEADER;
#ifdef REVOLVE_MUJOCO_VERSION
    mod.attr("MUJOCO_VERSION") = REVOLVE_MUJOCO_VERSION;  // the wheel built against
#else
    mod.attr("MUJOCO_VERSION") = "";
#endif
    mod.attr("RUNNING") = static_cast<int>(kRunning);
    mod.attr("DONE") = static_cast<int>(kDone);
    mod.attr("SCREEN") = static_cast<int>(kScreen);
    mod.attr("FALLBACK") = static_cast<int>(kFallback);
    mod.def("mujoco_version", []() { return mj_version(); }, "mj_version() of the loaded libmujoco.");

    nb::class_<Rollout>(mod, "Rollout", "Robots in scenes of their own, evaluated in C++.")
        .def(
            "__init__",
            [](Rollout* self, int insertion_ticks, int evaluation_ticks, int brain_stride, int substeps,
               double control_period, double servo_k, double max_velocity, double target_scale, double gravity,
               Vec<double> imu_high, Vec<double> light, double light_range, bool light_signal) {
                if (insertion_ticks < 0 || evaluation_ticks < 1 || brain_stride < 1) {
                    throw nb::value_error("bad rollout settings");
                }
                Settings s;
                set_physics(s, substeps, control_period, servo_k, max_velocity, gravity, imu_high, light,
                            light_range, "bad rollout settings");
                s.insertion_ticks = insertion_ticks;
                s.evaluation_ticks = evaluation_ticks;
                s.brain_stride = brain_stride;
                s.target_scale = target_scale;
                s.light_signal = light_signal;
                new (self) Rollout(s);
            },
            nb::arg("insertion_ticks"), nb::arg("evaluation_ticks"), nb::arg("brain_stride"), nb::arg("substeps"),
            nb::arg("control_period"), nb::arg("servo_k"), nb::arg("max_velocity"), nb::arg("target_scale"),
            nb::arg("gravity"), nb::arg("imu_high"), nb::arg("light"), nb::arg("light_range"),
            nb::arg("light_signal") = false)
        .def("add", &add, "Add a robot (its scene's raw mjModel*/mjData* and layout); returns its index.")
        .def(
            "run", [](Rollout& ro, int threads) {
                bool finished;
                {
                    nb::gil_scoped_release release;
                    finished = ro.run(threads);
                }
                if (!finished) throw nb::python_error();  // KeyboardInterrupt, say
            },
            nb::arg("threads") = 1, "Run every running robot until it is done or stops (GIL released).")
        .def("status", [](Rollout& ro, int i) { return ro.robot(i).status; }, nb::arg("index"))
        .def("time", [](Rollout& ro, int i) { return ro.robot(i).time; }, nb::arg("index"))
        .def("resume", &Rollout::resume, nb::arg("index"), nb::arg("blown"))
        .def(
            "path",
            [](Rollout& ro, int i) {
                Robot& r = ro.robot(i);
                return copy_array(r.path.data(), r.path.size(), {static_cast<std::size_t>(r.rows), 3});
            },
            nb::arg("index"), "The core's recorded positions, (rows, 3). Metres.")
        .def(
            "signal",
            [](Rollout& ro, int i) {
                Robot& r = ro.robot(i);
                return copy_array(r.signal.data(), r.signal.size(), {r.signal.size()});
            },
            nb::arg("index"), "The task signal at the recorded rows (empty without one).")
        .def(
            "state",
            [](Rollout& ro, int i) {
                // The robot's BodyStates row now (MujocoBackend.read), for blowups.reason.
                Robot& r = ro.robot(i);
                const std::size_t J = r.hinge_qpos.size();
                std::vector<double> jp(J), jv(J);
                for (std::size_t k = 0; k < J; ++k) {
                    jp[k] = r.d->qpos[r.hinge_qpos[k]];
                    jv[k] = r.d->qvel[r.hinge_dof[k]];
                }
                double w[3];
                Rollout::angvel(r, w);
                return nb::make_tuple(copy_array(r.d->qpos + r.root_qpos, 3, {1, 3}),
                                      copy_array(r.d->xmat + 9 * r.root_body, 9, {1, 3, 3}),
                                      copy_array(r.d->qvel + r.root_dof, 3, {1, 3}), copy_array(w, 3, {1, 3}),
                                      copy_array(jp.data(), J, {J}), copy_array(jv.data(), J, {J}));
            },
            nb::arg("index"), "(core_pos, core_rot, core_vel, core_angvel, joint_pos, joint_vel) now.");

    nb::class_<WorldStep>(mod, "WorldStep", "One control period of every robot of a MuJoCo scene, in C++.")
        .def("__init__", &make_world_step, nb::arg("model"), nb::arg("data"), nb::arg("substeps"),
             nb::arg("control_period"), nb::arg("servo_k"), nb::arg("max_velocity"), nb::arg("gravity"),
             nb::arg("imu_high"), nb::arg("light"), nb::arg("light_range"), nb::arg("root_body"),
             nb::arg("root_qpos"), nb::arg("root_dof"), nb::arg("hinge_qpos"), nb::arg("hinge_dof"),
             nb::arg("joint_start"), nb::arg("input_start"), nb::arg("n_inputs"), nb::arg("ctrl_qpos"),
             nb::arg("touch_body"), nb::arg("touch_dest"), nb::arg("light_body"), nb::arg("light_row"),
             nb::arg("light_dest"), nb::arg("light_point"), nb::arg("light_facing"), nb::arg("screen"))
        .def_prop_ro("states_size", &WorldStep::states_size, "Entries of step()'s states array.")
        .def("step", &world_step, nb::arg("targets"), nb::arg("start"), nb::arg("states"), nb::arg("sensors"),
             "One control period (GIL released); CALM, UNSETTLED, REPLAY or RESTART.");
    mod.attr("CALM") = static_cast<int>(WorldStep::kCalm);
    mod.attr("UNSETTLED") = static_cast<int>(WorldStep::kUnsettled);
    mod.attr("REPLAY") = static_cast<int>(WorldStep::kReplay);
    mod.attr("RESTART") = static_cast<int>(WorldStep::kRestart);

    // The kernels over n rows, checked against NumPy's at import (revolve_env.world.compiled).
    mod.def(
        "imu_products",
        [](nb::ndarray<const double, nb::shape<-1, 2, 3>, nb::c_contig, nb::device::cpu> rows,
           nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu> rot) {
            const std::size_t n = rows.shape(0);
            if (rot.shape(0) != n) throw nb::value_error("rows and rot differ in length");
            std::vector<double> out(6 * n);
            for (std::size_t k = 0; k < n; ++k) imu_product(rows.data() + 6 * k, rot.data() + 9 * k, out.data() + 6 * k);
            return copy_array(out.data(), out.size(), {n, 2, 3});
        },
        nb::arg("rows"), nb::arg("rot"), "rows @ rot, (n, 2, 3) @ (n, 3, 3).");
    mod.def(
        "einsum_products",
        [](nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu> rot, Mat3 w) {
            const std::size_t n = rot.shape(0);
            if (w.shape(0) != n) throw nb::value_error("rot and w differ in length");
            std::vector<double> out(3 * n);
            for (std::size_t k = 0; k < n; ++k) einsum_product(rot.data() + 9 * k, w.data() + 3 * k, out.data() + 3 * k);
            return copy_array(out.data(), out.size(), {n, 3});
        },
        nb::arg("rot"), nb::arg("w"), "einsum('nij,nj->ni', rot, w).");
    mod.def(
        "falloff_values",
        [](Mat3 pos, Vec<double> light, double light_range) {
            const std::size_t n = pos.shape(0);
            if (light.shape(0) != 3) throw nb::value_error("light must have 3 values");
            std::vector<double> out(n);
            for (std::size_t k = 0; k < n; ++k) out[k] = falloff_value(pos.data() + 3 * k, light.data(), light_range);
            return copy_array(out.data(), n, {n});
        },
        nb::arg("pos"), nb::arg("light"), nb::arg("light_range"), "sensing.light_falloff.");
    mod.def(
        "light_values",
        [](Mat3 pos, nb::ndarray<const double, nb::shape<-1, 3, 3>, nb::c_contig, nb::device::cpu> rot, Mat3 point,
           Mat3 facing, Vec<double> light, double light_range) {
            const std::size_t n = pos.shape(0);
            if (rot.shape(0) != n || point.shape(0) != n || facing.shape(0) != n || light.shape(0) != 3) {
                throw nb::value_error("sensor arrays differ in length");
            }
            std::vector<double> out(n);
            for (std::size_t k = 0; k < n; ++k) {
                out[k] = light_value(pos.data() + 3 * k, rot.data() + 9 * k, point.data() + 3 * k,
                                     facing.data() + 3 * k, light.data(), light_range);
            }
            return copy_array(out.data(), n, {n});
        },
        nb::arg("pos"), nb::arg("rot"), nb::arg("point"), nb::arg("facing"), nb::arg("light"), nb::arg("light_range"),
        "sensing.light_intensity.");

    // Locomotion's step (LocomotionEnv on MuJoCo) and its window, for revolve_env.world.compiled.EnvStep.
    nb::class_<BoundEnvStep>(mod, "EnvStep", "One step of the single-robot env on a WorldStep, in C++.")
        .def("__init__", &make_env_step, nb::arg("world"), nb::arg("targets").noconvert(),
             nb::arg("outputs").noconvert(), nb::arg("start").noconvert(), nb::arg("out").noconvert(), nb::arg("n_act"),
             nb::arg("n_inputs"), nb::arg("active"), nb::arg("proprioception"), nb::arg("low"), nb::arg("high"),
             nb::arg("target_scale"), nb::arg("task_kind"), nb::arg("s_weight"), nb::arg("limit"),
             nb::arg("cos_h"), nb::arg("sin_h"), nb::arg("window"), nb::arg("insertion"), nb::arg("stride"),
             nb::arg("signal_inputs"), nb::arg("network").none(), nb::arg("brain_dt"), nb::arg("brain_stride"))
        .def("step", &env_step<float>, nb::arg("action").noconvert(), nb::arg("obs").noconvert(),
             nb::arg("states").noconvert(), nb::arg("sensors").noconvert(), nb::arg("periods"), nb::arg("age"),
             nb::arg("time"),
             "One env step (GIL released): ENV_DONE, ENV_BAD_ACTION, ENV_BRAIN_DIVERGED or the period's outcome.")
        .def("step", &env_step<double>, nb::arg("action").noconvert(), nb::arg("obs").noconvert(),
             nb::arg("states").noconvert(), nb::arg("sensors").noconvert(), nb::arg("periods"), nb::arg("age"),
             nb::arg("time"))
        .def(
            "set_world", [](BoundEnvStep& e, nb::handle world, Out start) {
                WorldStep& w = nb::cast<WorldStep&>(world);
                if (w.n_ != 1 || w.n_inputs_ != e.n_in || w.m_->nu != e.n_out || w.J_ != e.w->J_ ||
                    start.shape(0) != static_cast<std::size_t>(w.state_size())) {
                    throw nb::value_error("another world's step");
                }
                e.w = &w;
                e.start = start;
                e.world = nb::borrow(world);  // the world it stepped before is let go
            },
            nb::arg("world"), nb::arg("start").noconvert(),
            "Step this world's step (its backend's start buffer) from now on (a remade scene).")
        .def_prop_rw(
            "terms", [](BoundEnvStep& e) { return nb::make_tuple(e.terms[0], e.terms[1], e.terms[2]); },
            [](BoundEnvStep& e, std::tuple<double, double, double> t) {
                e.terms[0] = std::get<0>(t);
                e.terms[1] = std::get<1>(t);
                e.terms[2] = std::get<2>(t);
            },
            "The task's fitness, v and s after the last step (metres).")
        .def("window_holds", [](BoundEnvStep& e, long age) { return e.window.holds(age); }, nb::arg("age"))
        .def(
            "window_push",
            [](BoundEnvStep& e, double time, double x, double y, long age, std::optional<double> signal) {
                return e.window.push(time, x, y, age, signal.has_value(), signal.value_or(0.0));
            },
            nb::arg("time"), nb::arg("x"), nb::arg("y"), nb::arg("age"), nb::arg("signal").none(),
            "RobotWindow.push; 0, or why not (1: time not finite, 2: before the last, 3: position, 4: signal).")
        .def(
            "window_terms",
            [](BoundEnvStep& e) {
                double t[3];
                e.window.terms(e.rule, t);
                return nb::make_tuple(t[0], t[1], t[2]);
            },
            "The task's fitness, v and s of the window now (zeros below two samples).")
        .def(
            "window_last",
            [](BoundEnvStep& e) {
                const EnvWindow::Sample s = e.window.last();
                return nb::make_tuple(s.x, s.y, s.signal);
            })
        .def("window_len", [](BoundEnvStep& e) { return e.window.samples.size(); })
        .def("window_clear", [](BoundEnvStep& e) { e.window.samples.clear(); });
    mod.attr("ENV_DONE") = static_cast<int>(EnvStep::kDone);
    mod.attr("ENV_BAD_ACTION") = static_cast<int>(EnvStep::kBadAction);
    mod.attr("ENV_BRAIN_DIVERGED") = static_cast<int>(EnvStep::kBrainDiverged);
    mod.def(
        "py_hypots",
        [](Vec<double> a, Vec<double> b) {
            const std::size_t n = a.shape(0);
            if (b.shape(0) != n) throw nb::value_error("a and b differ in length");
            std::vector<double> out(n);
            for (std::size_t k = 0; k < n; ++k) out[k] = py_hypot(a(k), b(k));
            return copy_array(out.data(), n, {n});
        },
        nb::arg("a"), nb::arg("b"), "math.hypot of each pair, as CPython computes it.");
    bind_array_rules(mod);  // pybullet's World: the rules over arrays
    bind_population_periods(mod);  // the population env's periods (revolve_env.world.compiled.PopulationPeriods)
    // The population env's fitness windows (revolve_env.world.compiled.WindowPush).
    // (the arrays it writes are taken as they are: a converted copy would take the writes)
    mod.def("windows_push", &windows::push, nb::arg("t"), nb::arg("window"), nb::arg("eps"), nb::arg("stride"),
            nb::arg("insertion"), nb::arg("position"), nb::arg("ages"), nb::arg("sampling"),
            nb::arg("ring_t").noconvert(), nb::arg("ring_xy").noconvert(), nb::arg("ring_path").noconvert(),
            nb::arg("first").noconvert(), nb::arg("last").noconvert(), nb::arg("seq"), nb::arg("start"),
            nb::arg("w_first").noconvert(), nb::arg("w_last").noconvert(), nb::arg("w_v").noconvert(),
            nb::arg("w_s").noconvert(), nb::arg("w_count").noconvert(), nb::arg("w_duration").noconvert(),
            "FitnessWindows.push (with TaskWindows' held poses) then .current(), in place; (pushed, seq, start, "
            "all_started).");
}
