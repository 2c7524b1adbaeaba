// mlspaces inspect FILE.xml [--json] [--emit-mjcf]: compose + compile any MJCF and print what
// MuJoCo made of it (sim::DescribeModel: bodies with world pose, mass and geom box; joints;
// actuators; cameras).
#include <array>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "mlspaces/core/json.h"
#include "mlspaces/sim/describe.h"
#include "mlspaces/sim/mjcf_composer.h"

namespace mlspaces::cli {
namespace {

struct InspectFlags {
  std::string file;
  bool json = false;
  bool emit = false;
};

template <size_t N>
std::string Vec(const std::array<double, N>& v) {
  std::string out = "[";
  for (size_t k = 0; k < N; ++k) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%s%.6g", k ? ", " : "", v[k]);
    out += buf;
  }
  return out + "]";
}

std::string Name(const std::string& name) { return name.empty() ? "(unnamed)" : name; }

int Run(const InspectFlags& flags) {
  sim::MjcfComposer composer(flags.file);
  if (flags.emit) {
    std::printf("%s", composer.Emit().c_str());
    return 0;
  }
  const sim::ModelDescription model = sim::DescribeModel(composer, flags.file);
  if (flags.json) {
    std::printf("%s\n", DumpJsonIndent4(sim::ToJson(model)).c_str());
    return 0;
  }
  // Text for people: 6 significant digits, names shown as "(unnamed)" when MuJoCo has none.
  std::printf("%s: %zu bodies, %zu joints, %lld geoms, %zu actuators, %zu cameras\n",
              flags.file.c_str(), model.bodies.size(), model.joints.size(),
              static_cast<long long>(model.ngeom), model.actuators.size(), model.cameras.size());
  std::printf("bodies (world pose at qpos0; box = world-axes box of the body's own geoms):\n");
  for (const sim::BodyDescription& b : model.bodies) {
    std::printf("  %-24s pos %s quat %s mass %.6g", Name(b.name).c_str(), Vec(b.pose.pos).c_str(),
                Vec(b.pose.quat).c_str(), b.mass);
    if (b.box) std::printf(" box %s..%s", Vec((*b.box)[0]).c_str(), Vec((*b.box)[1]).c_str());
    std::printf("\n");
  }
  if (!model.joints.empty()) std::printf("joints:\n");
  for (const sim::JointDescription& j : model.joints) {
    std::printf("  %-24s %-6s body %s%s%s\n", Name(j.name).c_str(), j.type.c_str(), j.body.c_str(),
                j.range ? " range " : "", j.range ? Vec(*j.range).c_str() : "");
  }
  if (!model.actuators.empty()) std::printf("actuators:\n");
  for (const sim::ActuatorDescription& a : model.actuators) {
    std::printf("  %-24s %s %s\n", Name(a.name).c_str(), a.transmission.c_str(), a.target.c_str());
  }
  if (!model.cameras.empty()) std::printf("cameras:\n");
  for (const sim::CameraDescription& c : model.cameras) {
    std::printf("  %-24s body %s pos %s\n", Name(c.name).c_str(), c.body.c_str(),
                Vec(c.pos).c_str());
  }
  for (const Diagnostic& w : model.warnings) Warn(sim::MujocoWarningLine(w));
  return 0;
}

}  // namespace

void AddInspect(CLI::App& app, Action& action) {
  auto flags = std::make_shared<InspectFlags>();
  CLI::App* sub = app.add_subcommand(
      "inspect", "Compose and compile an MJCF; print bodies, joints, actuators and cameras");
  sub->add_option("FILE", flags->file, "MJCF file (MuJoCo 3 <frame>/<attach> allowed)")->required();
  sub->add_flag("--json", flags->json, "Print JSON for scripts");
  sub->add_flag("--emit-mjcf", flags->emit, "Print the flat MJCF handed to MuJoCo 2.2.2");
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
