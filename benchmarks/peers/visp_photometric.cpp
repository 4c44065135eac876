// ViSP 3.5's photometric visual servoing on a given texture, for benchmarks/peers/visp_photometric.py.
//
// Usage: visp_photometric TEXTURE.pgm TARGET.pgm PARAMS
//   TEXTURE.pgm  the grey-level texture, mapped by vpImageSimulator (bilinear) onto the rectangle
//                +-half_w x +-half_h of the plane z = 0 of the object frame;
//   TARGET.pgm   an image (the caller's own rendering at the target) whose luminance feature and
//                interaction matrix vpFeatureLuminance computes;
//   PARAMS       a text file of whitespace-separated numbers:
//                width height px py u0 v0 Z half_w half_h
//                cdMo (12 numbers: the 3 x 4 rows of the target camera's object pose)
//                cMo  (12 numbers: the start)
//                lambda mu_initial mu_final mu_switch_frames frames dt saturate (1: the default
//                velocity limits of vpSimulatorCamera, 1 m/s and 90 deg/s; 0: none)
//
// Prints one JSON object: "L" (the interaction matrix of TARGET.pgm, row-major), "rendered_target"
// (vpImageSimulator's image at cdMo, row-major), and "run": for each frame k of ViSP's own loop
// (vpImageSimulator + vpFeatureLuminance at the target + the Levenberg-Marquardt law
// v = -lambda (H + mu diag H)^-1 L*^T (I - I*) + vpSimulatorCamera), the camera's cMo before the
// frame's twist, the twist, the error's sum of squares, and the times of the step's three parts in
// microseconds: the image (vpImageSimulator::getImage), the feature and its error (buildFrom,
// error) and the law (as ViSP's photometricVisualServoing example writes it).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <visp3/core/vpCameraParameters.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpImage.h>
#include <visp3/io/vpImageIo.h>
#include <visp3/robot/vpImageSimulator.h>
#include <visp3/robot/vpSimulatorCamera.h>
#include <visp3/visual_features/vpFeatureLuminance.h>

namespace {

vpHomogeneousMatrix pose(const std::vector<double> &p, std::size_t at) {
  vpHomogeneousMatrix M;
  for (unsigned r = 0; r < 3; ++r)
    for (unsigned c = 0; c < 4; ++c) M[r][c] = p[at + 4 * r + c];
  return M;
}

void print_array(const char *name, const std::vector<double> &x, bool last = false) {
  std::printf("\"%s\": [", name);
  for (std::size_t i = 0; i < x.size(); ++i) std::printf("%s%.17g", i ? ", " : "", x[i]);
  std::printf("]%s", last ? "" : ", ");
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s TEXTURE.pgm TARGET.pgm PARAMS\n", argv[0]);
    return 2;
  }
  std::ifstream in(argv[3]);
  std::vector<double> p;
  for (double v; in >> v;) p.push_back(v);
  if (p.size() != 9 + 24 + 7) {
    std::fprintf(stderr, "PARAMS: %zu numbers, 40 expected\n", p.size());
    return 2;
  }
  const unsigned width = static_cast<unsigned>(p[0]), height = static_cast<unsigned>(p[1]);
  const vpCameraParameters cam(p[2], p[3], p[4], p[5]);
  const double Z = p[6], half_w = p[7], half_h = p[8];
  const vpHomogeneousMatrix cdMo = pose(p, 9), cMo_start = pose(p, 21);
  const double lambda = p[33], mu_initial = p[34], mu_final = p[35];
  const int mu_switch = static_cast<int>(p[36]), frames = static_cast<int>(p[37]);
  const double dt = p[38];
  const bool saturate = p[39] != 0.0;

  vpImage<unsigned char> texture, target;
  vpImageIo::read(texture, argv[1]);
  vpImageIo::read(target, argv[2]);

  // the caller's target image: the feature and its interaction matrix
  vpFeatureLuminance given;
  given.init(height, width, Z);
  given.setCameraParameters(const_cast<vpCameraParameters &>(cam));
  given.buildFrom(target);
  vpMatrix L_given;
  given.interaction(L_given);

  // ViSP's own scene: the texture on the plane, imaged by vpImageSimulator
  vpColVector X[4];
  const double corners[4][2] = {{-half_w, -half_h}, {half_w, -half_h}, {half_w, half_h}, {-half_w, half_h}};
  for (int i = 0; i < 4; ++i) {
    X[i].resize(3);
    X[i][0] = corners[i][0];
    X[i][1] = corners[i][1];
    X[i][2] = 0.0;
  }
  vpImageSimulator sim;
  sim.setInterpolationType(vpImageSimulator::BILINEAR_INTERPOLATION);
  sim.init(texture, X);
  vpImage<unsigned char> Id(height, width, 0), I(height, width, 0);
  sim.setCameraPosition(cdMo);
  sim.getImage(Id, cam);

  vpFeatureLuminance sId, sI;
  sId.init(height, width, Z);
  sId.setCameraParameters(const_cast<vpCameraParameters &>(cam));
  sId.buildFrom(Id);
  sI.init(height, width, Z);
  sI.setCameraParameters(const_cast<vpCameraParameters &>(cam));
  vpMatrix Lsd;
  sId.interaction(Lsd);
  const vpMatrix Hsd = Lsd.AtA();
  vpMatrix diagHsd(6, 6);
  diagHsd.eye(6);
  for (unsigned i = 0; i < 6; ++i) diagHsd[i][i] = Hsd[i][i];

  vpSimulatorCamera robot;
  robot.setSamplingTime(dt);
  if (!saturate) {
    robot.setMaxTranslationVelocity(1e9);
    robot.setMaxRotationVelocity(1e9);
  }
  robot.setPosition(cMo_start.inverse());  // wMc, the object frame as the world frame
  std::vector<double> poses, twists, sum_squares, image_us, feature_us, law_us;
  vpColVector error, v;
  for (int k = 0; k < frames; ++k) {
    const vpHomogeneousMatrix cMo = robot.getPosition().inverse();
    for (unsigned r = 0; r < 3; ++r)
      for (unsigned c = 0; c < 4; ++c) poses.push_back(cMo[r][c]);
    const auto t0 = std::chrono::steady_clock::now();
    sim.setCameraPosition(cMo);
    sim.getImage(I, cam);
    const auto t1 = std::chrono::steady_clock::now();
    sI.buildFrom(I);
    sI.error(sId, error);
    const auto t2 = std::chrono::steady_clock::now();
    const double mu = k < mu_switch ? mu_initial : mu_final;
    const vpMatrix H = ((mu * diagHsd) + Hsd).inverseByLU();
    v = -lambda * (H * Lsd.t() * error);
    const auto t3 = std::chrono::steady_clock::now();
    image_us.push_back(1e6 * std::chrono::duration<double>(t1 - t0).count());
    feature_us.push_back(1e6 * std::chrono::duration<double>(t2 - t1).count());
    law_us.push_back(1e6 * std::chrono::duration<double>(t3 - t2).count());
    sum_squares.push_back(error.sumSquare());
    for (unsigned i = 0; i < 6; ++i) twists.push_back(v[i]);
    robot.setVelocity(vpRobot::CAMERA_FRAME, v);
  }

  std::vector<double> L(L_given.data, L_given.data + L_given.size());
  std::vector<double> rendered(Id.bitmap, Id.bitmap + Id.getSize());
  std::printf("{\"rows\": %u, ", L_given.getRows());
  print_array("L", L);
  print_array("rendered_target", rendered);
  std::printf("\"run\": {");
  print_array("cMo", poses);
  print_array("twist", twists);
  print_array("sum_squares", sum_squares);
  print_array("image_us", image_us);
  print_array("feature_us", feature_us);
  print_array("law_us", law_us, true);
  std::printf("}}\n");
  return 0;
}
