// Prints libsdformat's resolution of an SDF file as JSON: for every model (nested ones with a
// "::"-scoped path), its pose in its parent (model frame or world) and every link, joint and
// frame pose in that model's frame, plus joint axes in the model frame.
// Build: g++ -std=c++17 sdf_oracle.cc $(pkg-config --cflags --libs sdformat12) -o sdf_oracle
#include <iostream>
#include <sstream>
#include <string>

#include <sdf/sdf.hh>

namespace {

using Pose = ignition::math::Pose3d;

std::string Num(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

std::string PoseJson(const Pose &p) {
  return "[" + Num(p.Pos().X()) + "," + Num(p.Pos().Y()) + "," + Num(p.Pos().Z()) + "," +
         Num(p.Rot().W()) + "," + Num(p.Rot().X()) + "," + Num(p.Rot().Y()) + "," +
         Num(p.Rot().Z()) + "]";
}

std::string Quote(const std::string &s) { return "\"" + s + "\""; }

void Model(const sdf::Model *model, const std::string &path, bool first_model, std::ostream &out) {
  Pose in_parent;
  model->SemanticPose().Resolve(in_parent);
  if (!first_model) out << ",";
  out << "{\"path\":" << Quote(path) << ",\"pose_in_parent\":" << PoseJson(in_parent);
  out << ",\"links\":{";
  for (uint64_t i = 0; i < model->LinkCount(); ++i) {
    const sdf::Link *link = model->LinkByIndex(i);
    Pose pose;
    link->SemanticPose().Resolve(pose, "__model__");
    out << (i ? "," : "") << Quote(link->Name()) << ":" << PoseJson(pose);
  }
  out << "},\"joints\":{";
  bool first = true;
  for (uint64_t i = 0; i < model->JointCount(); ++i) {
    const sdf::Joint *joint = model->JointByIndex(i);
    Pose pose;
    if (!joint->SemanticPose().Resolve(pose, "__model__").empty()) continue;
    out << (first ? "" : ",") << Quote(joint->Name()) << ":{\"pose\":" << PoseJson(pose);
    first = false;
    const sdf::JointAxis *axis = joint->Axis(0);
    ignition::math::Vector3d xyz;
    if (axis != nullptr && axis->ResolveXyz(xyz, "__model__").empty()) {
      out << ",\"axis\":[" << Num(xyz.X()) << "," << Num(xyz.Y()) << "," << Num(xyz.Z()) << "]";
    }
    out << "}";
  }
  out << "},\"frames\":{";
  for (uint64_t i = 0; i < model->FrameCount(); ++i) {
    const sdf::Frame *frame = model->FrameByIndex(i);
    Pose pose;
    frame->SemanticPose().Resolve(pose, "__model__");
    out << (i ? "," : "") << Quote(frame->Name()) << ":" << PoseJson(pose);
  }
  out << "}}";
  for (uint64_t i = 0; i < model->ModelCount(); ++i) {
    const sdf::Model *nested = model->ModelByIndex(i);
    Model(nested, path.empty() ? nested->Name() : path + "::" + nested->Name(), false, out);
  }
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 2) {
    std::cerr << "usage: sdf_oracle file.sdf\n";
    return 2;
  }
  sdf::Root root;
  sdf::Errors errors = root.Load(argv[1]);
  std::ostringstream out;
  out << "{\"errors\":" << errors.size() << ",\"scope\":";
  if (root.Model() != nullptr) {
    out << "\"model\",\"models\":[";
    Model(root.Model(), "", true, out);
  } else {
    out << "\"world\",\"models\":[";
    bool first = true;
    for (uint64_t w = 0; w < root.WorldCount(); ++w) {
      const sdf::World *world = root.WorldByIndex(w);
      for (uint64_t i = 0; i < world->ModelCount(); ++i) {
        Model(world->ModelByIndex(i), world->ModelByIndex(i)->Name(), first, out);
        first = false;
      }
    }
  }
  out << "]}";
  std::cout << out.str() << std::endl;
  return 0;
}
