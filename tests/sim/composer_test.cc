// MJCF composer (MuJoCo's parser and mjSpec): what users see of a composed model (poses, masses,
// names, keyframes, errors) against values worked out by hand.
#include "mlspaces/sim/mjcf_composer.h"

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "test_util.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kData = MLSPACES_TESTDATA_DIR;
constexpr double kEps = 1e-9;
const double kH = std::sqrt(0.5);

struct Compiled {
  ModelPtr m;
  DataPtr d;
  int Body(const char* name) const {
    int id = mj_name2id(m.get(), mjOBJ_BODY, name);
    EXPECT_GE(id, 0) << name;
    return id;
  }
};

Compiled Load(const MjcfComposer& c) {
  Compiled out;
  out.m = c.Compile();
  out.d = MakeData(out.m.get());
  mj_kinematics(out.m.get(), out.d.get());
  return out;
}

void ExpectPos(const Compiled& c, const char* body, double x, double y, double z) {
  int b = c.Body(body);
  ASSERT_GE(b, 0);
  EXPECT_NEAR(c.d->xpos[3 * b], x, kEps) << body;
  EXPECT_NEAR(c.d->xpos[3 * b + 1], y, kEps) << body;
  EXPECT_NEAR(c.d->xpos[3 * b + 2], z, kEps) << body;
}

// Quaternions compared up to sign.
void ExpectQuat(const Compiled& c, const char* body, double w, double x, double y, double z) {
  int b = c.Body(body);
  ASSERT_GE(b, 0);
  const double* q = c.d->xquat + 4 * b;
  double sign = (q[0] * w + q[1] * x + q[2] * y + q[3] * z) < 0 ? -1 : 1;
  EXPECT_NEAR(sign * q[0], w, kEps) << body;
  EXPECT_NEAR(sign * q[1], x, kEps) << body;
  EXPECT_NEAR(sign * q[2], y, kEps) << body;
  EXPECT_NEAR(sign * q[3], z, kEps) << body;
}

TEST(Composer, TwoAttachesOfOneModelWithPrefixesAndRotatedFrames) {
  Compiled c = Load(MjcfComposer(kData / "compose/two_links.xml"));
  EXPECT_EQ(c.m->nbody, 4);  // world, a/link, b/link, own
  EXPECT_EQ(c.m->ngeom, 6);  // floor + 2 x 2 + own
  // Frame pos (1,0,0) rotated 90 deg about z; body pos (0,0,0.1) and its own yaw of pi/2
  // (radians in the model file) -> yaw pi.
  ExpectPos(c, "a/link", 1, 0, 0.1);
  ExpectQuat(c, "a/link", 0, 0, 0, 1);
  // Frames (0,1,0) then Rx(90 deg): (0,0,0.1) -> (0,-0.1,0); quat Rx90 * Rz90.
  ExpectPos(c, "b/link", 0, 0.9, 0);
  ExpectQuat(c, "b/link", 0.5, 0.5, -0.5, 0.5);
  // The model's own defaults: box 0.2x0.1x0.05 at 500 kg/m3 + sphere r 0.1 at 2000 kg/m3;
  // the scene's density 1 does not leak in, but applies to the scene's own 1 m cube.
  const double link_mass = 0.5 + 2000 * 4.0 / 3.0 * std::numbers::pi * 0.001;
  EXPECT_NEAR(c.m->body_mass[c.Body("a/link")], link_mass, 1e-9);
  EXPECT_NEAR(c.m->body_mass[c.Body("b/link")], link_mass, 1e-9);
  EXPECT_NEAR(c.m->body_mass[c.Body("own")], 1.0, 1e-12);
  // References carry the prefix: each motor drives its own joint, each sensor reads it.
  int ja = mj_name2id(c.m.get(), mjOBJ_JOINT, "a/hinge");
  int jb = mj_name2id(c.m.get(), mjOBJ_JOINT, "b/hinge");
  ASSERT_GE(ja, 0);
  ASSERT_GE(jb, 0);
  EXPECT_EQ(c.m->actuator_trnid[2 * mj_name2id(c.m.get(), mjOBJ_ACTUATOR, "a/m")], ja);
  EXPECT_EQ(c.m->actuator_trnid[2 * mj_name2id(c.m.get(), mjOBJ_ACTUATOR, "b/m")], jb);
  EXPECT_EQ(c.m->sensor_objid[mj_name2id(c.m.get(), mjOBJ_SENSOR, "b/s")], jb);
  // Radians in the model file stay radians.
  EXPECT_NEAR(c.m->jnt_range[2 * ja + 1], 1.0, 1e-12);
}

TEST(Composer, NestedFramesIncludesAndOrientationForms) {
  Compiled c = Load(MjcfComposer(kData / "compose/nested_frames.xml"));
  EXPECT_EQ(c.m->nbody, 4);  // world, included, b, c
  EXPECT_EQ(c.m->ngeom, 4);
  ExpectPos(c, "included", 0, 0, 3);
  EXPECT_NEAR(c.m->body_mass[c.Body("included")], 0.5, 1e-12);
  // (1,0,0) + (0,2,0) + Rz90 (1,0,0) = (1,3,0).
  ExpectPos(c, "b", 1, 3, 0);
  ExpectQuat(c, "b", kH, 0, 0, kH);
  EXPECT_NEAR(c.m->body_mass[c.Body("b")], 8.0, 1e-9);  // 0.2 m cube at 1000 kg/m3
  // Frame inside b at (0,0,1) with zaxis (1,0,0) = Ry90; body (0,0,1) -> (1,0,0) -> (1,0,1) in
  // b, then Rz90 and b's position: (1,4,1); quat Rz90 * Ry90.
  ExpectPos(c, "c", 1, 4, 1);
  ExpectQuat(c, "c", 0.5, -0.5, 0.5, 0.5);
  // xyaxes (0,1,0),(-1,0,0) is Rz90: the capsule from (0,0,0)-(1,0,0) goes to (0,0,5)-(0,1,5).
  int g = mj_name2id(c.m.get(), mjOBJ_GEOM, "loose");
  ASSERT_GE(g, 0);
  EXPECT_NEAR(c.d->geom_xpos[3 * g], 0, kEps);
  EXPECT_NEAR(c.d->geom_xpos[3 * g + 1], 0.5, kEps);
  EXPECT_NEAR(c.d->geom_xpos[3 * g + 2], 5, kEps);
  EXPECT_NEAR(c.m->geom_size[3 * g + 1], 0.5, kEps);  // half-length
}

TEST(Composer, EulerSequencePerFile) {
  const char* intrinsic = R"(<mujoco><compiler eulerseq="xyz"/><worldbody>
      <body name="q" euler="90 90 0"><geom type="sphere" size="1"/></body></worldbody></mujoco>)";
  const char* extrinsic = R"(<mujoco><compiler eulerseq="XYZ"/><worldbody>
      <body name="q" euler="90 90 0"><geom type="sphere" size="1"/></body></worldbody></mujoco>)";
  // Rx90 * Ry90 (moving axes) vs Ry90 * Rx90 (fixed axes).
  ExpectQuat(Load(MjcfComposer::FromString(intrinsic, kData / "i.xml")), "q", .5, .5, .5, .5);
  ExpectQuat(Load(MjcfComposer::FromString(extrinsic, kData / "e.xml")), "q", .5, .5, .5, -.5);
}

TEST(Composer, SeedTutorialScene) {
  MjcfComposer composer(kData / "custom_assets/scene.xml");
  Compiled c = Load(composer);
  EXPECT_EQ(c.m->nbody, 2);
  EXPECT_EQ(c.m->ngeom, 2);  // floor + block
  EXPECT_EQ(c.m->nlight, 2);
  EXPECT_EQ(c.m->opt.integrator, mjINT_IMPLICIT);
  ExpectPos(c, "red_block", 0.4, 0, 0.025);
  ExpectQuat(c, "red_block", 1, 0, 0, 0);
  EXPECT_NEAR(c.m->body_mass[c.Body("red_block")], 0.125, 1e-15);
  // The freejoint's qpos0 is the attached pose.
  EXPECT_NEAR(c.m->qpos0[0], 0.4, kEps);
  EXPECT_NEAR(c.m->qpos0[2], 0.025, kEps);
  EXPECT_EQ(c.m->nmat, 1);
  EXPECT_EQ(c.m->ntex, 1);
  // Emit writes plain MJCF: attachments expanded, frames folded into the bodies.
  std::string flat = composer.Emit();
  EXPECT_THAT(flat, ::testing::Not(HasSubstr("<frame")));
  EXPECT_THAT(flat, ::testing::Not(HasSubstr("<attach")));
  EXPECT_THAT(flat, ::testing::Not(HasSubstr("<model")));
}

TEST(Composer, DegreeDefaultsAreConvertedPerFile) {
  Compiled c = Load(MjcfComposer(kData / "two_link_arm.xml"));
  int shoulder = mj_name2id(c.m.get(), mjOBJ_JOINT, "shoulder");
  int elbow = mj_name2id(c.m.get(), mjOBJ_JOINT, "elbow");
  int finger = mj_name2id(c.m.get(), mjOBJ_JOINT, "finger_slide");
  EXPECT_NEAR(c.m->jnt_range[2 * shoulder + 1], std::numbers::pi / 2, 1e-12);  // 90 from default
  EXPECT_NEAR(c.m->jnt_range[2 * elbow], -std::numbers::pi / 4, 1e-12);        // -45 own
  EXPECT_EQ(c.m->jnt_type[finger], mjJNT_SLIDE);
  EXPECT_NEAR(c.m->jnt_range[2 * finger + 1], 0.04, 1e-12);  // slide: metres, unconverted
  EXPECT_EQ(c.m->jnt_limited[shoulder], 1);                  // autolimits, as in MuJoCo 3
}

TEST(Composer, RuntimeAttachOfRobotAndObject) {
  MjcfComposer scene(kData / "custom_assets/scene.xml");
  Pose base;
  base.pos = {-0.5, 0, 0};
  base.quat = {kH, 0, 0, kH};  // yaw 90
  auto bodies = scene.Attach(kData / "two_link_arm.xml", "world", "robot_0/", base);
  ASSERT_EQ(bodies.size(), 1u);
  EXPECT_EQ(bodies[0], "robot_0/base");
  Pose on_block;
  on_block.pos = {0, 0, 0.1};
  scene.Attach(kData / "facts/rotated_cylinder.xml", "red_block", "obj_1/", on_block);
  EXPECT_TRUE(scene.HasBody("obj_1/cyl"));
  Compiled c = Load(scene);
  EXPECT_EQ(c.m->nbody, 2 + 4 + 1);
  EXPECT_EQ(c.m->nu, 2);
  ExpectPos(c, "robot_0/base", -0.5, 0, 0.05);
  // link1 at (0,0,0.05) in base; link2 at (0.3,0,0) in link1, rotated by the base's yaw.
  ExpectPos(c, "robot_0/link2", -0.5, 0.3, 0.1);
  ExpectQuat(c, "robot_0/link2", 0, 0, 0, 1);  // yaw 90 + 90
  // Under the block at (0.4,0,0.025): cyl's own pos (5,0,0) + (0,0,0.1).
  ExpectPos(c, "obj_1/cyl", 5.4, 0, 0.125);
  int act = mj_name2id(c.m.get(), mjOBJ_ACTUATOR, "robot_0/elbow_act");
  EXPECT_EQ(c.m->actuator_trnid[2 * act], mj_name2id(c.m.get(), mjOBJ_JOINT, "robot_0/elbow"));
  int s = mj_name2id(c.m.get(), mjOBJ_SENSOR, "robot_0/tcp_pos");
  EXPECT_EQ(c.m->sensor_objid[s], mj_name2id(c.m.get(), mjOBJ_SITE, "robot_0/tcp"));
  EXPECT_THROW(scene.Attach(kData / "two_link_arm.xml", "no_such_body", "r/", Pose{}), Error);
}

TEST(Composer, AttachOneBodyOfAModel) {
  const char* xml = R"(<mujoco><asset><model name="arm" file="two_link_arm.xml"/></asset>
    <worldbody><frame pos="0 0 1"><attach model="arm" body="link2" prefix="p/"/></frame>
    </worldbody></mujoco>)";
  Compiled c = Load(MjcfComposer::FromString(xml, kData / "inline.xml"));
  EXPECT_EQ(c.m->nbody, 3);  // world, p/link2, p/finger
  ExpectPos(c, "p/link2", 0.3, 0, 1);
  EXPECT_EQ(c.m->nu, 1);  // only the elbow actuator refers to the subtree
  EXPECT_EQ(c.m->nsensor, 1);
}

TEST(Composer, AttachedKeyframesArePrefixedAndPaddedDefaultsStayPerModel) {
  Compiled c = Load(MjcfComposer(kData / "compose/keyed_scene.xml"));
  ASSERT_EQ(c.m->nkey, 3);
  ASSERT_EQ(c.m->nq, 7 + 2 + 2);
  const int start = mj_name2id(c.m.get(), mjOBJ_KEY, "start");
  const int a = mj_name2id(c.m.get(), mjOBJ_KEY, "a/home");
  const int b = mj_name2id(c.m.get(), mjOBJ_KEY, "b/home");
  ASSERT_GE(start, 0);
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  const double* ka = c.m->key_qpos + a * c.m->nq;
  const double* kb = c.m->key_qpos + b * c.m->nq;
  // a/home: the arm's own values on a's joints (degrees file: qpos is not converted), the
  // rest of the model at qpos0 (the box's free joint at its body pose).
  EXPECT_NEAR(ka[2], 1.0, kEps);
  EXPECT_NEAR(ka[7], 0.5, kEps);
  EXPECT_NEAR(ka[8], 0.01, kEps);
  EXPECT_NEAR(ka[9], 0.0, kEps);
  EXPECT_NEAR(kb[7], 0.0, kEps);
  EXPECT_NEAR(kb[9], 0.5, kEps);
  EXPECT_NEAR(c.m->key_qpos[start * c.m->nq + 10], 0.4, kEps);
  // Each arm keeps its own defaults: density 300 (not the scene's 1), class "soft" damping 3
  // (not the scene's class of that name, 99), its degrees.
  EXPECT_NEAR(c.m->body_mass[c.Body("a/base")], 300 * 0.008, 1e-9);
  EXPECT_NEAR(c.m->body_mass[c.Body("box")], 0.008, 1e-12);
  const int slide = mj_name2id(c.m.get(), mjOBJ_JOINT, "b/slide");
  ASSERT_GE(slide, 0);
  EXPECT_NEAR(c.m->dof_damping[c.m->jnt_dofadr[slide]], 3.0, 1e-12);
  const int swing = mj_name2id(c.m.get(), mjOBJ_JOINT, "a/swing");
  EXPECT_NEAR(c.m->jnt_range[2 * swing + 1], std::numbers::pi / 2, 1e-12);
  ExpectPos(c, "b/tip", 2.2, 0, 0.1);
}

TEST(Composer, CompileLeavesTheComposerAsItWasAndCopiesAreIndependent) {
  MjcfComposer scene(kData / "custom_assets/scene.xml");
  ModelPtr first = scene.Compile();
  ModelPtr again = scene.Compile();
  EXPECT_EQ(first->nbody, 2);
  EXPECT_EQ(again->nbody, 2);
  MjcfComposer copy = scene;
  copy.Attach(kData / "compose/keyed_arm.xml", "world", "arm/", Pose{});
  EXPECT_TRUE(copy.HasBody("arm/base"));
  EXPECT_FALSE(scene.HasBody("arm/base"));
  EXPECT_EQ(copy.Compile()->nbody, 4);
  EXPECT_EQ(scene.Compile()->nbody, 2);
  // Attaching after a compile still works; the same prefix twice is a name clash naming the
  // attached file twice.
  copy.Attach(kData / "compose/keyed_arm.xml", "red_block", "arm2/", Pose{});
  EXPECT_EQ(copy.Compile()->nbody, 6);
  copy.Attach(kData / "compose/keyed_arm.xml", "world", "arm/", Pose{});
  try {
    copy.Compile();
    FAIL() << "no error for a repeated name";
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), HasSubstr("'arm/base'"));
    EXPECT_THAT(e.message(), HasSubstr("keyed_arm.xml line 11 and "));
    EXPECT_EQ(fs::path(e.path()).filename(), "keyed_arm.xml");
    EXPECT_EQ(e.field(), "line 11, element <body>");
  }
}

TEST(Composer, AParsedModelAttachesAsOftenAsWanted) {
  const MjcfComposer arm(kData / "two_link_arm.xml");
  EXPECT_EQ(arm.TopLevelBodies(), std::vector<std::string>{"base"});
  MjcfComposer scene(kData / "custom_assets/scene.xml");
  EXPECT_EQ(scene.TopLevelBodies(), std::vector<std::string>{"red_block"});
  Pose left, right;
  left.pos = {0, 1, 0};
  right.pos = {0, -1, 0};
  EXPECT_EQ(scene.Attach(arm, "world", "l/", left), std::vector<std::string>{"l/base"});
  EXPECT_EQ(scene.Attach(arm, "world", "r/", right), std::vector<std::string>{"r/base"});
  Compiled c = Load(scene);
  EXPECT_EQ(c.m->nu, 4);
  ExpectPos(c, "l/base", 0, 1, 0.05);
  ExpectPos(c, "r/base", 0, -1, 0.05);
  EXPECT_EQ(arm.Compile()->nbody, 5);  // the attached model is unchanged
  const MjcfComposer physics(kData / "two_link_arm.xml", ComposeOptions{.physics_only = true});
  EXPECT_THROW(scene.Attach(physics, "world", "p/", Pose{}), Error);
  EXPECT_THROW(scene.Attach(scene, "world", "self/", Pose{}), Error);
  // Text attached at run time: errors name the path it was given for.
  try {
    scene.AttachString(
        "<mujoco>\n<worldbody>\n<body><geom size=\"x\"/></body>\n</worldbody>\n</mujoco>",
        kData / "generated.xml", "world", "g/", Pose{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(fs::path(e.path()).filename(), "generated.xml");
    EXPECT_EQ(e.field(), "line 3, element <geom>");
  }
}

TEST(Composer, RuntimeAttachErrorsNameTheFileAndLine) {
  MjcfComposer scene(kData / "custom_assets/scene.xml");
  try {
    scene.Attach(kData / "two_link_arm.xml", "no_such_body", "r/", Pose{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), HasSubstr("no body named 'no_such_body'"));
    EXPECT_EQ(fs::path(e.path()).filename(), "scene.xml");
  }
  try {
    scene.Attach(kData / "bad/unknown_element.xml", "world", "r/", Pose{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(fs::path(e.path()).filename(), "unknown_element.xml");
    EXPECT_EQ(e.field(), "line 5, element <gizmo>");
  }
  EXPECT_THROW(scene.Attach(kData / "no_such_file.xml", "world", "r/", Pose{}), Error);
  EXPECT_THROW(scene.Attach(kData / "two_link_arm.xml", "world", "r/", Pose{}, "no_body"), Error);
  // A model with a dangling reference (which MuJoCo's attach would silently leave out) is an
  // error at Attach, against its own file; the scene is unchanged.
  try {
    scene.Attach(kData / "bad/dangling_ref.xml", "world", "d/", Pose{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(fs::path(e.path()).filename(), "dangling_ref.xml");
    EXPECT_EQ(e.field(), "line 8, element <motor>");
    EXPECT_THAT(e.message(), HasSubstr("no_such_joint"));
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  EXPECT_FALSE(scene.HasBody("d/b"));
  EXPECT_EQ(scene.Compile()->nbody, 2);
}

TEST(Composer, EmitLoadsFromAnyFolderAndAttachStringResolvesBesideItsPath) {
  MjcfComposer scene(kData / "custom_assets/scene.xml");
  scene.Attach(kData / "facts/neg_tet/neg_tet.xml", "world", "tet/", Pose{});
  const char* probe = R"(<mujoco><worldbody><body name="probe" pos="0 0 2">
      <geom type="sphere" size="0.1" mass="3"/></body></worldbody></mujoco>)";
  auto bodies = scene.AttachString(probe, kData / "facts/probe.xml", "world", "", Pose{});
  ASSERT_EQ(bodies, std::vector<std::string>{"probe"});
  ModelPtr direct = scene.Compile();
  // The emitted MJCF names the mesh and texture files absolutely: it loads from memory.
  ModelPtr reloaded = LoadModelFromMemory(scene.Emit(), "elsewhere.xml");
  EXPECT_EQ(reloaded->nbody, direct->nbody);
  EXPECT_EQ(reloaded->nmesh, 1);
  EXPECT_EQ(reloaded->ntex, 2);
  const int p = mj_name2id(reloaded.get(), mjOBJ_BODY, "probe");
  ASSERT_EQ(p, direct->nbody - 1);  // attached last: the last body
  EXPECT_NEAR(reloaded->body_mass[p], 3.0, 1e-12);
  const int t = mj_name2id(direct.get(), mjOBJ_BODY, "tet/neg_tet");
  ASSERT_GE(t, 0);
  EXPECT_NEAR(reloaded->body_mass[t], direct->body_mass[t], 1e-6 * direct->body_mass[t]);
}

TEST(Composer, CopyOfAModelWithADanglingReferenceIsAnError) {
  // MuJoCo's mj_copySpec drops the motor on a missing joint; the copy must not hide the error.
  const MjcfComposer bad(kData / "bad/dangling_ref.xml");
  try {
    MjcfComposer copy = bad;  // NOLINT(performance-unnecessary-copy-initialization): the test
    FAIL() << "copied without an error";
  } catch (const Error& e) {
    EXPECT_EQ(fs::path(e.path()).filename(), "dangling_ref.xml");
    EXPECT_EQ(e.field(), "line 8, element <motor>");
  }
}

TEST(Composer, EmitOfAModelWithIncludesNamesItsMeshFilesAbsolutely) {
  // MuJoCo reads an included file's mesh relative to the including model and its meshdir.
  const mlspaces::testing::TempDir tmp;
  fs::create_directories(tmp / "meshes");
  fs::create_directories(tmp / "parts");
  fs::copy_file(kData / "facts/neg_tet/neg_tet.obj", tmp / "meshes/neg_tet.obj");
  WriteFileAtomic(tmp / "parts/assets.xml",
                  "<mujoco><asset><mesh file=\"neg_tet.obj\"/></asset></mujoco>\n");
  WriteFileAtomic(tmp / "main.xml",
                  "<mujoco><compiler meshdir=\"meshes\"/><include file=\"parts/assets.xml\"/>\n"
                  "<worldbody><body name=\"t\"><geom type=\"mesh\" mesh=\"neg_tet\"/></body>"
                  "</worldbody></mujoco>\n");
  MjcfComposer c(tmp / "main.xml");
  const double mass = c.Compile()->body_mass[1];
  ModelPtr reloaded = LoadModelFromMemory(c.Emit(), "elsewhere.xml");
  EXPECT_NEAR(reloaded->body_mass[1], mass, 1e-6 * mass);
}

TEST(Composer, SpecEditsAndVfsFilesReachTheCompile) {
  MjcfComposer c(kData / "facts/neg_tet/neg_tet.xml", ComposeOptions{.physics_only = true});
  const double mass = c.Compile()->body_mass[1];
  // The same tetrahedron at twice the size, handed over in memory: 8 times the mass.
  const std::string obj =
      "v 0 0 0\nv -0.2 0 0\nv 0 -0.2 0\nv 0 0 -0.2\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n";
  mjsElement* mesh = mjs_firstElement(c.spec(), mjOBJ_MESH);
  ASSERT_NE(mesh, nullptr);
  mjs_setString(mjs_asMesh(mesh)->file, "in_memory_tet.obj");
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  ASSERT_EQ(mj_addBufferVFS(&vfs, "in_memory_tet.obj", obj.data(), static_cast<int>(obj.size())),
            0);
  ModelPtr big = c.Compile(&vfs);
  mj_deleteVFS(&vfs);
  EXPECT_NEAR(big->body_mass[1], 8 * mass, 1e-9 * mass);
}

struct BadCase {
  const char* file;
  const char* where_file;
  const char* field;
  const char* message;
};

// gtest prints a case (and ctest names it) by its file, not as raw bytes.
void PrintTo(const BadCase& bad, std::ostream* os) { *os << bad.file; }

class BadMjcf : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadMjcf, OneLineWithFileLineAndElement) {
  const BadCase& bad = GetParam();
  try {
    MjcfComposer(kData / "bad" / bad.file).Compile();
    FAIL() << "no error for " << bad.file;
  } catch (const Error& e) {
    EXPECT_EQ(fs::path(e.path()).filename().string(), bad.where_file);
    EXPECT_EQ(e.field(), bad.field);
    EXPECT_THAT(e.message(), HasSubstr(bad.message));
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BadMjcf,
    ::testing::Values(
        BadCase{"unknown_element.xml", "unknown_element.xml", "line 5, element <gizmo>",
                "unrecognized element"},
        BadCase{"missing_mesh.xml", "missing_mesh.xml", "line 3, element <mesh>", "file not found"},
        BadCase{"bad_number.xml", "bad_number.xml", "line 3, element <body>",
                "bad format in attribute 'pos'"},
        BadCase{"dangling_ref.xml", "dangling_ref.xml", "line 8, element <motor>", "no_such_joint"},
        BadCase{"unknown_model.xml", "unknown_model.xml", "line 4, element <attach>",
                "could not find model 'nope'"},
        BadCase{"bad_nested_attach.xml", "unknown_element.xml", "line 5, element <gizmo>",
                "unrecognized element"},
        BadCase{"bad_xml.xml", "bad_xml.xml", "line 3", "XML parse error"},
        // MuJoCo gives elements of an included file line 0; the error names that file.
        BadCase{"include_bad_element.xml", "inc_gizmo.xml", "line 6, element <gizmo>",
                "unrecognized element"},
        BadCase{"include_malformed.xml", "inc_malformed.xml", "line 3", "XML parse error"},
        BadCase{"missing_model.xml", "missing_model.xml", "line 4, element <model>",
                "no_such_model.xml"},
        // A compile error in an attached model: that model's file and line.
        BadCase{"attached_dangling.xml", "dangling_arm.xml", "line 11, element <motor>",
                "no_such_joint"}),
    // The file's stem: Cases/BadMjcf.OneLineWithFileLineAndElement/unknown_element.
    [](const ::testing::TestParamInfo<BadCase>& info) {
      std::string name = fs::path(info.param.file).stem().string();
      for (char& c : name) {
        if (std::isalnum(static_cast<unsigned char>(c)) == 0) c = '_';
      }
      return name;
    });

TEST(Composer, NameClashNamesBothFiles) {
  try {
    MjcfComposer(kData / "bad/name_clash.xml").Emit();
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), HasSubstr("'x/link'"));
    EXPECT_THAT(e.message(), HasSubstr("name_clash.xml line 6"));
    EXPECT_THAT(e.message(), HasSubstr("arm_link.xml line 11"));
  }
}

TEST(Composer, PhysicsOnlyKeepsMassesAndDropsRendering) {
  MjcfComposer full(kData / "facts/neg_tet/neg_tet.xml");
  MjcfComposer fast(kData / "facts/neg_tet/neg_tet.xml", ComposeOptions{.physics_only = true});
  Compiled a = Load(full), b = Load(fast);
  EXPECT_EQ(a.m->ntex, 1);
  EXPECT_EQ(b.m->ntex, 0);
  EXPECT_EQ(b.m->nmat, 0);
  EXPECT_EQ(a.m->body_mass[1], b.m->body_mass[1]);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.m->body_inertia[3 + i], b.m->body_inertia[3 + i]);
}

}  // namespace
}  // namespace mlspaces::sim
