// ViSP 3.5's tutorial-ibvs-4pts, timed: four coplanar points, vpServo (EYEINHAND_CAMERA, L at the
// current features, lambda 0.5) and vpSimulatorCamera at 40 ms, the depths from the simulated
// points (vpFeatureBuilder::create from a tracked vpPoint), as in the tutorial's loop.
//
// Usage: visp_ibvs_4pts [steps] [repeats]
// Runs the tutorial's loop `steps` iterations, `repeats` times from the same start, timing every
// iteration alone (steady_clock): the camera pose from the simulator, the four points projected
// and their features updated, computeControlLaw and setVelocity. Prints one JSON object: ViSP's
// version, the per-iteration summary over all repeats, and the features (x, y per point) and the
// twist of the first repeat after each iteration, for the trajectory check.
#include <visp3/core/vpConfig.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpMath.h>
#include <visp3/core/vpPoint.h>
#include <visp3/robot/vpSimulatorCamera.h>
#include <visp3/visual_features/vpFeatureBuilder.h>
#include <visp3/visual_features/vpFeaturePoint.h>
#include <visp3/vs/vpServo.h>

#include <iostream>
#include <string>
#include <vector>

#include "harness.h"

int main(int argc, char **argv) {
  const long steps = peer::arg(argc, argv, 1, 150);
  const long repeats = peer::arg(argc, argv, 2, 20);
  std::vector<double> iteration_s;
  std::vector<double> features, twists;  // per iteration of the first repeat: 8 features, 6 twist
  double v_max = 0.0, w_max = 0.0;       // largest |v_i|, |w_i| commanded (saturation check)
  for (long r = 0; r < repeats; ++r) {
    vpHomogeneousMatrix cdMo(0, 0, 0.75, 0, 0, 0);
    vpHomogeneousMatrix cMo(0.15, -0.1, 1., vpMath::rad(10), vpMath::rad(-10), vpMath::rad(50));
    vpPoint point[4];
    point[0].setWorldCoordinates(-0.1, -0.1, 0);
    point[1].setWorldCoordinates(0.1, -0.1, 0);
    point[2].setWorldCoordinates(0.1, 0.1, 0);
    point[3].setWorldCoordinates(-0.1, 0.1, 0);
    vpServo task;
    task.setServo(vpServo::EYEINHAND_CAMERA);
    task.setInteractionMatrixType(vpServo::CURRENT);
    task.setLambda(0.5);
    vpFeaturePoint p[4], pd[4];
    for (unsigned int i = 0; i < 4; i++) {
      point[i].track(cdMo);
      vpFeatureBuilder::create(pd[i], point[i]);
      point[i].track(cMo);
      vpFeatureBuilder::create(p[i], point[i]);
      task.addFeature(p[i], pd[i]);
    }
    vpHomogeneousMatrix wMc, wMo;
    vpSimulatorCamera robot;
    robot.setSamplingTime(0.040);
    robot.getPosition(wMc);
    wMo = wMc * cMo;
    for (long iter = 0; iter < steps; iter++) {
      const auto t0 = peer::Clock::now();
      robot.getPosition(wMc);
      cMo = wMc.inverse() * wMo;
      for (unsigned int i = 0; i < 4; i++) {
        point[i].track(cMo);
        vpFeatureBuilder::create(p[i], point[i]);
      }
      vpColVector v = task.computeControlLaw();
      robot.setVelocity(vpRobot::CAMERA_FRAME, v);
      const auto t1 = peer::Clock::now();
      iteration_s.push_back(peer::seconds(t0, t1));
      if (r == 0) {
        for (unsigned int i = 0; i < 4; i++) {
          features.push_back(p[i].get_x());
          features.push_back(p[i].get_y());
        }
        for (unsigned int j = 0; j < 6; j++) twists.push_back(v[j]);
        for (unsigned int j = 0; j < 3; j++) v_max = std::max(v_max, std::abs(v[j]));
        for (unsigned int j = 3; j < 6; j++) w_max = std::max(w_max, std::abs(v[j]));
      }
    }
  }
  std::cout << "{\"peer\": \"visp\", \"visp_version\": \"" << VISP_VERSION_MAJOR << "." << VISP_VERSION_MINOR
            << "." << VISP_VERSION_PATCH << "\", \"steps\": " << steps << ", \"repeats\": " << repeats
            << ", \"iteration\": " << peer::summary_us(iteration_s) << ", \"features\": " << peer::array(features)
            << ", \"twists\": " << peer::array(twists) << ", \"v_max\": " << v_max << ", \"w_max\": " << w_max
            << "}" << std::endl;
  return 0;
}
