// MuJoCo C physics as XLA FFI handlers on the CPU: the native backend's env step and reset without
// a Python round trip (swim_jax/envs/physics/native_ffi.py builds this file on first use and registers it).
//
// A call gets every lane of a (possibly vmapped) step at once: rows of the float64 state bits
// (qpos, qvel, qacc_warmstart as uint32 pairs) and of the controls, or rows of qpos and qvel for a
// reset. Per lane it does what swim_jax/envs/physics/native.py's Python path does with mujoco.batch:
//   step:  ctrl = action; frame_skip x mj_step; mj_rnePostConstraint if the task reads contact forces
//   reset: mj_resetData; qpos, qvel set; mj_forward
// and writes the new state bits and one row of what the task reads (qpos, qvel, xpos, cfrc_ext; the
// last zero unless the task reads contact forces) in the env dtype.
//
// Models are registered under a key (a hash of the model's bytes, computed in Python) as copies
// owned by this library, so a compiled program refers to a model by content, never by a pointer.

#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include <mujoco/mujoco.h>

#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

namespace {

struct Model {
  mjModel* model = nullptr;
  std::vector<mjData*> lanes;  // one MjData per lane, reused by every call (state is set each call)
  std::mutex mu;               // one call at a time per model (two programs may run at once)
};

std::mutex registry_mu;
std::unordered_map<int64_t, std::unique_ptr<Model>>& Registry() {
  static auto* registry = new std::unordered_map<int64_t, std::unique_ptr<Model>>();
  return *registry;
}

Model* Find(int64_t key) {
  std::lock_guard<std::mutex> lock(registry_mu);
  auto it = Registry().find(key);
  return it == Registry().end() ? nullptr : it->second.get();
}

// Reads element i of a float32 or float64 buffer as a double.
double Read(const ffi::AnyBuffer& b, int64_t i) {
  if (b.element_type() == ffi::DataType::F32) return static_cast<const float*>(b.untyped_data())[i];
  return static_cast<const double*>(b.untyped_data())[i];
}

void Write(ffi::Result<ffi::AnyBuffer>& b, int64_t i, double v) {
  if (b->element_type() == ffi::DataType::F32) {
    static_cast<float*>(b->untyped_data())[i] = static_cast<float>(v);
  } else {
    static_cast<double*>(b->untyped_data())[i] = v;
  }
}

bool Floating(ffi::DataType t) { return t == ffi::DataType::F32 || t == ffi::DataType::F64; }

// The rows of one lane's outputs from its MjData.
void Emit(const mjModel* m, const mjData* d, bool contact_forces, int64_t lane, uint32_t* exact,
          ffi::Result<ffi::AnyBuffer>& view) {
  const int64_t nq = m->nq, nv = m->nv, nb = m->nbody;
  double* state = reinterpret_cast<double*>(exact + lane * 2 * (nq + 2 * nv));
  std::memcpy(state, d->qpos, nq * sizeof(double));
  std::memcpy(state + nq, d->qvel, nv * sizeof(double));
  std::memcpy(state + nq + nv, d->qacc_warmstart, nv * sizeof(double));
  const int64_t row = lane * (nq + nv + 9 * nb);
  int64_t j = row;
  for (int64_t i = 0; i < nq; ++i) Write(view, j++, d->qpos[i]);
  for (int64_t i = 0; i < nv; ++i) Write(view, j++, d->qvel[i]);
  for (int64_t i = 0; i < 3 * nb; ++i) Write(view, j++, d->xpos[i]);
  for (int64_t i = 0; i < 6 * nb; ++i) Write(view, j++, contact_forces ? d->cfrc_ext[i] : 0.0);
}

ffi::Error Unregistered(int64_t key) {
  return ffi::Error(ffi::ErrorCode::kNotFound, "swim-jax native physics: model key " + std::to_string(key) +
                                                   " is not registered in this process (build the env first)");
}

// Checks a call's buffers against the model (rows of `in_row` and `second_row` elements per lane,
// floating-point controls and view) and makes sure there is one MjData per lane; sets `lanes`.
ffi::Error Prepare(Model* model, int64_t in_row, int64_t in_elements, const ffi::AnyBuffer* second,
                   int64_t second_row, ffi::ResultBuffer<ffi::U32>& exact,
                   ffi::Result<ffi::AnyBuffer>& view, int64_t* lanes) {
  const mjModel* m = model->model;
  const int64_t n = in_row > 0 ? in_elements / in_row : 0;
  if (in_row <= 0 || n * in_row != in_elements || second->element_count() != n * second_row ||
      exact->element_count() != n * 2 * (m->nq + 2 * m->nv) ||
      view->element_count() != n * (m->nq + m->nv + 9 * m->nbody) || !Floating(view->element_type()) ||
      !Floating(second->element_type())) {
    return ffi::Error(ffi::ErrorCode::kInvalidArgument, "swim-jax native physics: buffer sizes do not match the model");
  }
  while (static_cast<int64_t>(model->lanes.size()) < n) model->lanes.push_back(mj_makeData(m));
  *lanes = n;
  return ffi::Error::Success();
}

ffi::Error Step(ffi::Buffer<ffi::U32> state, ffi::AnyBuffer ctrl, ffi::ResultBuffer<ffi::U32> exact,
                ffi::Result<ffi::AnyBuffer> view, int64_t key, int64_t frame_skip, int64_t contact_forces) {
  Model* model = Find(key);
  if (model == nullptr) return Unregistered(key);
  std::lock_guard<std::mutex> lock(model->mu);
  const mjModel* m = model->model;
  const int64_t nq = m->nq, nv = m->nv, nu = m->nu;
  int64_t n = 0;
  ffi::Error err = Prepare(model, 2 * (nq + 2 * nv), state.element_count(), &ctrl, nu, exact, view, &n);
  if (err.failure()) return err;
  const double* rows = reinterpret_cast<const double*>(state.typed_data());
  for (int64_t lane = 0; lane < n; ++lane) {
    mjData* d = model->lanes[lane];
    const double* s = rows + lane * (nq + 2 * nv);
    std::memcpy(d->qpos, s, nq * sizeof(double));
    std::memcpy(d->qvel, s + nq, nv * sizeof(double));
    std::memcpy(d->qacc_warmstart, s + nq + nv, nv * sizeof(double));
    for (int64_t i = 0; i < nu; ++i) d->ctrl[i] = Read(ctrl, lane * nu + i);
    for (int64_t k = 0; k < frame_skip; ++k) mj_step(m, d);
    if (contact_forces) mj_rnePostConstraint(m, d);
    Emit(m, d, contact_forces != 0, lane, exact->typed_data(), view);
  }
  return ffi::Error::Success();
}

ffi::Error Reset(ffi::AnyBuffer qpos, ffi::AnyBuffer qvel, ffi::ResultBuffer<ffi::U32> exact,
                 ffi::Result<ffi::AnyBuffer> view, int64_t key, int64_t contact_forces) {
  Model* model = Find(key);
  if (model == nullptr) return Unregistered(key);
  std::lock_guard<std::mutex> lock(model->mu);
  const mjModel* m = model->model;
  const int64_t nq = m->nq, nv = m->nv;
  int64_t n = 0;
  if (!Floating(qpos.element_type())) {
    return ffi::Error(ffi::ErrorCode::kInvalidArgument, "swim-jax native physics: qpos must be float32 or float64");
  }
  ffi::Error err = Prepare(model, nq, qpos.element_count(), &qvel, nv, exact, view, &n);
  if (err.failure()) return err;
  for (int64_t lane = 0; lane < n; ++lane) {
    mjData* d = model->lanes[lane];
    mj_resetData(m, d);
    for (int64_t i = 0; i < nq; ++i) d->qpos[i] = Read(qpos, lane * nq + i);
    for (int64_t i = 0; i < nv; ++i) d->qvel[i] = Read(qvel, lane * nv + i);
    mj_forward(m, d);
    Emit(m, d, contact_forces != 0, lane, exact->typed_data(), view);
  }
  return ffi::Error::Success();
}

}  // namespace

extern "C" {

// Registers a copy of the model at `model` under `key` (no-op if the key exists). Returns 0.
int swim_native_register(int64_t key, const void* model) {
  std::lock_guard<std::mutex> lock(registry_mu);
  auto& slot = Registry()[key];
  if (!slot) {
    slot = std::make_unique<Model>();
    slot->model = mj_copyModel(nullptr, static_cast<const mjModel*>(model));
  }
  return 0;
}

}  // extern "C"

XLA_FFI_DEFINE_HANDLER_SYMBOL(SwimNativeStep, Step,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::Buffer<ffi::U32>>()
                                  .Arg<ffi::AnyBuffer>()
                                  .Ret<ffi::Buffer<ffi::U32>>()
                                  .Ret<ffi::AnyBuffer>()
                                  .Attr<int64_t>("key")
                                  .Attr<int64_t>("frame_skip")
                                  .Attr<int64_t>("contact_forces"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(SwimNativeReset, Reset,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::AnyBuffer>()
                                  .Arg<ffi::AnyBuffer>()
                                  .Ret<ffi::Buffer<ffi::U32>>()
                                  .Ret<ffi::AnyBuffer>()
                                  .Attr<int64_t>("key")
                                  .Attr<int64_t>("contact_forces"));
