// pneumatic.Simulation: an mjData of a model, stepped with mj_step (the GIL released), its state as
// numpy arrays that alias MuJoCo's memory, and the chambers' absolute pressures.
#include <mutex>
#include <string>
#include <vector>

#include <pybind11/numpy.h>

#include "pneumatic/pneumatic.h"
#include "python/bindings.h"

namespace pneumatic::python {
namespace {

class Simulation {
 public:
  explicit Simulation(ModelHandle model) : model_(std::move(model)), data_(mj_makeData(model_->get()), mj_deleteData) {
    if (!data_) throw RunError("MuJoCo could not allocate the data of " + model_->path);
  }

  // n steps of mj_step; RuntimeError naming the time if MuJoCo found the state diverged (it then
  // resets the data, as it does)
  void Step(long n) {
    if (n < 0) throw InputError("step(n): n must be 0 or more, not " + std::to_string(n));
    const mjModel* m = model_->get();
    mjData* d = data_.get();
    const int bad_before = Diverged(d);
    double diverged_at = 0;
    {
      py::gil_scoped_release release;
      std::shared_lock lock(model_->lock);
      for (long i = 0; i < n; ++i) {
        diverged_at = d->time;
        mj_step(m, d);
        if (Diverged(d) != bad_before) break;
      }
    }
    if (Diverged(d) != bad_before) {
      throw RunError("the simulation diverged at t = " + std::to_string(diverged_at) +
                     " s (MuJoCo's bad qacc or qvel): MuJoCo reset the state");
    }
  }

  void Reset(py::object keyframe) {
    const mjModel* m = model_->get();
    if (keyframe.is_none()) {
      mj_resetData(m, data_.get());
      return;
    }
    const int key = keyframe.cast<int>();
    if (key < 0 || key >= m->nkey) {
      throw InputError("reset(keyframe=" + std::to_string(key) + "): the model has " + std::to_string(m->nkey) + " keyframes");
    }
    mj_resetDataKeyframe(m, data_.get(), key);
  }

  // the cylinders as the model's parameters are now (a set() may have changed p_atm)
  py::array_t<double> Pressures() const {
    std::shared_lock lock(model_->lock);
    const std::vector<CylinderInfo> cylinders = Cylinders(model_->get());
    py::array_t<double> out({static_cast<py::ssize_t>(cylinders.size()), static_cast<py::ssize_t>(2)});
    auto p = out.mutable_unchecked<2>();
    for (size_t i = 0; i < cylinders.size(); ++i) {
      p(i, 0) = ChamberPressure(model_->get(), data_.get(), cylinders[i], Chamber::kP);
      p(i, 1) = ChamberPressure(model_->get(), data_.get(), cylinders[i], Chamber::kN);
    }
    return out;
  }

  CylinderInfo Find(const std::string& name) const {
    std::shared_lock lock(model_->lock);
    for (const CylinderInfo& c : Cylinders(model_->get())) {
      if (c.name == name) return c;
    }
    throw InputError("the model " + model_->path + " has no cylinder '" + name + "'");
  }

  ModelHandle model_;
  std::unique_ptr<mjData, void (*)(mjData*)> data_;

 private:
  static int Diverged(const mjData* d) { return d->warning[mjWARN_BADQACC].number + d->warning[mjWARN_BADQVEL].number; }
};

// a writable view of one of mjData's arrays, and assignment into it (the size checked)
template <int Size(const mjModel*), mjtNum* mjData::*Field>
void AddArray(py::class_<Simulation>& c, const char* name, const char* doc) {
  c.def_property(
      name,
      [](py::object self) {
        Simulation& s = self.cast<Simulation&>();
        return py::array_t<double>({static_cast<py::ssize_t>(Size(s.model_->get()))},
                                   {static_cast<py::ssize_t>(sizeof(double))}, s.data_.get()->*Field, self);
      },
      [name](Simulation& s, const py::array_t<double, py::array::c_style | py::array::forcecast>& values) {
        const int n = Size(s.model_->get());
        if (values.ndim() != 1 || values.shape(0) != n) {
          throw InputError(std::string(name) + " takes " + std::to_string(n) + " numbers, not an array of shape " +
                           py::str(values.attr("shape")).cast<std::string>());
        }
        std::copy(values.data(), values.data() + n, s.data_.get()->*Field);
      },
      doc);
}

int Nq(const mjModel* m) { return m->nq; }
int Nv(const mjModel* m) { return m->nv; }
int Nu(const mjModel* m) { return m->nu; }
int Na(const mjModel* m) { return m->na; }

}  // namespace

void BindSimulation(py::module_& m) {
  py::class_<Simulation> c(m, "Simulation", "a model's state (MuJoCo's mjData), stepped with mj_step");
  c.def(py::init<ModelHandle>(), py::arg("model"), "the model's reset state: qpos0, chambers at atmospheric pressure")
      .def("step", &Simulation::Step, py::arg("n") = 1, "n steps of mj_step, without the GIL")
      .def("reset", &Simulation::Reset, py::arg("keyframe") = py::none(),
           "back to the reset state (mj_resetData), or to keyframe `keyframe`")
      .def("forward", [](Simulation& s) { mj_forward(s.model_->get(), s.data_.get()); },
           "mj_forward: the derived quantities of the current state, without stepping")
      .def_property(
          "time", [](const Simulation& s) { return s.data_->time; }, [](Simulation& s, double t) { s.data_->time = t; },
          "simulated time, s")
      .def_readonly("model", &Simulation::model_)
      .def("pressures", &Simulation::Pressures,
           "the chambers' absolute pressures, Pa: an array (cylinders, 2), rows in the order of model.cylinders, "
           "columns chambers P and N")
      .def(
          "pressure",
          [](const Simulation& s, const std::string& cylinder, const std::string& chamber) {
            if (chamber != "P" && chamber != "N") throw InputError("chamber is 'P' or 'N', not '" + chamber + "'");
            return ChamberPressure(s.model_->get(), s.data_.get(), s.Find(cylinder), chamber == "P" ? Chamber::kP : Chamber::kN);
          },
          py::arg("cylinder"), py::arg("chamber"), "one chamber's absolute pressure, Pa")
      .def(
          "set_pressure",
          [](Simulation& s, const std::string& cylinder, const std::string& chamber, double pressure) {
            if (chamber != "P" && chamber != "N") throw InputError("chamber is 'P' or 'N', not '" + chamber + "'");
            if (!(pressure > 0)) throw InputError("an absolute pressure is positive, not " + std::to_string(pressure) + " Pa");
            SetChamberPressure(s.model_->get(), s.data_.get(), s.Find(cylinder), chamber == "P" ? Chamber::kP : Chamber::kN,
                               pressure);
          },
          py::arg("cylinder"), py::arg("chamber"), py::arg("pressure"), "sets one chamber's absolute pressure, Pa")
      .def(
          "command",
          [](const Simulation& s, const std::string& column) {
            const size_t dot = column.find('.');
            const int id = dot == std::string::npos ? -1 : s.Find(column.substr(0, dot)).CommandActuator(column.substr(dot + 1));
            if (id < 0) throw InputError("'" + column + "' is not a command column of the model (\"<cylinder>.<signal>\", e.g. cyl.u)");
            return id;
          },
          py::arg("column"), "the index into ctrl of a command column, e.g. sim.ctrl[sim.command('cyl.u')] = 2.5");
  AddArray<Nq, &mjData::qpos>(c, "qpos", "joint positions (MuJoCo's memory, writable)");
  AddArray<Nv, &mjData::qvel>(c, "qvel", "joint velocities (MuJoCo's memory, writable)");
  AddArray<Nu, &mjData::ctrl>(c, "ctrl", "actuator controls: the valve commands (MuJoCo's memory, writable)");
  AddArray<Na, &mjData::act>(c, "act", "activations: chamber pressures as p - p_atm, Pa (MuJoCo's memory, writable)");
}

}  // namespace pneumatic::python
