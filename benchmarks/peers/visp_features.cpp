// ViSP 3.5 side of benchmarks/bench_peer_features.py: features and interaction matrices of ViSP's
// moment features (vpFeatureMomentCommon, discrete points) and polar point features
// (vpFeaturePointPolar), and a short moment servo run, on cases read from stdin.
//
// Built by benchmarks/peers/visp.py (g++, pkg-config visp); not a dependency of the package.
// Protocol: one request per line on stdin, one answer per line on stdout, numbers separated by
// spaces (%.17g):
//   moments n Zd Ad Bd Cd A B C xd_1 yd_1 ... xd_n yd_n x_1 y_1 ... x_n y_n
//     -> 6 features [xn yn an Px Py alpha], then the 6 x 6 interaction matrix row by row, then
//        ViSP's raw vpMomentCInvariant values 12 and 13 (Px, Py) and mu20 + mu02 of the image
//   polar n x_1 y_1 Z_1 ... x_n y_n Z_n
//     -> per point rho theta, then its 2 x 6 interaction matrix row by row
//   servo n lambda dt steps cMo(12: R row by row, t) cdMo(12) X_1 Y_1 Z_1 ... (object frame)
//     -> the camera pose cMo (12 numbers) after every step: the moment law with L at the desired
//        features (vpServo::DESIRED), pseudo-inverse, the pose updated by the exponential map
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <visp3/core/vpExponentialMap.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpMomentCInvariant.h>
#include <visp3/core/vpMomentCentered.h>
#include <visp3/core/vpMomentCommon.h>
#include <visp3/core/vpMomentObject.h>
#include <visp3/core/vpPlane.h>
#include <visp3/core/vpPoint.h>
#include <visp3/visual_features/vpFeatureMomentCommon.h>
#include <visp3/visual_features/vpFeaturePointPolar.h>
#include <visp3/vs/vpServo.h>

namespace
{
void put(std::ostream &out, double v) { out << ' ' << v; }

void put_matrix(std::ostream &out, const vpMatrix &M)
{
  for (unsigned int i = 0; i < M.getRows(); ++i)
    for (unsigned int j = 0; j < M.getCols(); ++j)
      put(out, M[i][j]);
}

std::vector<vpPoint> image_points(std::istream &in, unsigned int n)
{
  std::vector<vpPoint> pts(n);
  for (unsigned int k = 0; k < n; ++k) {
    double x, y;
    in >> x >> y;
    pts[k].set_x(x);
    pts[k].set_y(y);
  }
  return pts;
}

vpHomogeneousMatrix read_pose(std::istream &in)
{
  vpHomogeneousMatrix M;
  for (unsigned int i = 0; i < 3; ++i)
    for (unsigned int j = 0; j < 3; ++j)
      in >> M[i][j];
  for (unsigned int i = 0; i < 3; ++i)
    in >> M[i][3];
  return M;
}

// 1/Z = A x + B y + C of the object plane z_O = 0 seen from cMo (as ViSP's servoMomentPoints example)
void plane_abc(const vpHomogeneousMatrix &cMo, double &A, double &B, double &C)
{
  vpPlane pl;
  pl.setABCD(0, 0, 1.0, 0);
  pl.changeFrame(cMo);
  A = -pl.getA() / pl.getD();
  B = -pl.getB() / pl.getD();
  C = -pl.getC() / pl.getD();
}

std::vector<vpPoint> project(const std::vector<vpPoint> &object, const vpHomogeneousMatrix &cMo)
{
  std::vector<vpPoint> pts = object;
  for (auto &p : pts)
    p.track(cMo);
  return pts;
}

void moments(std::istream &in, std::ostream &out)
{
  unsigned int n;
  double Zd, Ad, Bd, Cd, A, B, C;
  in >> n >> Zd >> Ad >> Bd >> Cd >> A >> B >> C;
  std::vector<vpPoint> desired = image_points(in, n), current = image_points(in, n);
  vpMomentObject dst(6), src(6);
  dst.setType(vpMomentObject::DISCRETE);
  src.setType(vpMomentObject::DISCRETE);
  dst.fromVector(desired);
  src.fromVector(current);
  vpMomentCommon mdb(vpMomentCommon::getSurface(dst), vpMomentCommon::getMu3(dst), vpMomentCommon::getAlpha(dst), Zd);
  vpFeatureMomentCommon fmdb(mdb);
  mdb.updateAll(src);
  fmdb.updateAll(A, B, C);
  vpFeatureMomentGravityCenterNormalized &g = fmdb.getFeatureGravityNormalized();
  vpFeatureMomentAreaNormalized &an = fmdb.getFeatureAn();
  vpFeatureMomentCInvariant &ci = fmdb.getFeatureCInvariant();
  vpFeatureMomentAlpha &alpha = fmdb.getFeatureAlpha();
  const unsigned int px = 1 << 12, py = 1 << 13;
  vpColVector s_g = g.get_s(), s_an = an.get_s(), s_ci = ci.get_s(), s_alpha = alpha.get_s();
  put(out, s_g[0]);
  put(out, s_g[1]);
  put(out, s_an[0]);
  put(out, s_ci[12]);
  put(out, s_ci[13]);
  put(out, s_alpha[0]);
  put_matrix(out, g.interaction());
  put_matrix(out, an.interaction());
  put_matrix(out, ci.interaction(px));
  put_matrix(out, ci.interaction(py));
  put_matrix(out, alpha.interaction());
  bool found;
  const vpMomentCInvariant &inv = static_cast<const vpMomentCInvariant &>(mdb.get("vpMomentCInvariant", found));
  const vpMomentCentered &mu = static_cast<const vpMomentCentered &>(mdb.get("vpMomentCentered", found));
  put(out, inv.get(12));
  put(out, inv.get(13));
  put(out, mu.get(2, 0) + mu.get(0, 2));
}

void polar(std::istream &in, std::ostream &out)
{
  unsigned int n;
  in >> n;
  for (unsigned int k = 0; k < n; ++k) {
    double x, y, Z;
    in >> x >> y >> Z;
    vpFeaturePointPolar s;
    s.buildFrom(sqrt(x * x + y * y), atan2(y, x), Z);
    put(out, s.get_rho());
    put(out, s.get_theta());
    put_matrix(out, s.interaction());
  }
}

void servo(std::istream &in, std::ostream &out)
{
  unsigned int n, steps;
  double lambda, dt;
  in >> n >> lambda >> dt >> steps;
  vpHomogeneousMatrix cMo = read_pose(in), cdMo = read_pose(in);
  std::vector<vpPoint> object(n);
  for (auto &p : object) {
    double X, Y, Z;
    in >> X >> Y >> Z;
    p.setWorldCoordinates(X, Y, Z);
  }
  vpMomentObject dst(6), src(6);
  dst.setType(vpMomentObject::DISCRETE);
  src.setType(vpMomentObject::DISCRETE);
  std::vector<vpPoint> seen = project(object, cdMo);
  dst.fromVector(seen);
  seen = project(object, cMo);
  src.fromVector(seen);
  double Zd = cdMo[2][3], A, B, C, Ad, Bd, Cd;
  vpMomentCommon mdb(vpMomentCommon::getSurface(dst), vpMomentCommon::getMu3(dst), vpMomentCommon::getAlpha(dst), Zd);
  vpMomentCommon mdb_d(vpMomentCommon::getSurface(dst), vpMomentCommon::getMu3(dst), vpMomentCommon::getAlpha(dst), Zd);
  vpFeatureMomentCommon fmdb(mdb), fmdb_d(mdb_d);
  plane_abc(cMo, A, B, C);
  plane_abc(cdMo, Ad, Bd, Cd);
  mdb.updateAll(src);
  fmdb.updateAll(A, B, C);
  mdb_d.updateAll(dst);
  fmdb_d.updateAll(Ad, Bd, Cd);
  vpServo task;
  task.setServo(vpServo::EYEINHAND_CAMERA);
  task.setInteractionMatrixType(vpServo::DESIRED, vpServo::PSEUDO_INVERSE);
  task.addFeature(fmdb.getFeatureGravityNormalized(), fmdb_d.getFeatureGravityNormalized());
  task.addFeature(fmdb.getFeatureAn(), fmdb_d.getFeatureAn());
  task.addFeature(fmdb.getFeatureCInvariant(), fmdb_d.getFeatureCInvariant(), (1 << 12) | (1 << 13));
  task.addFeature(fmdb.getFeatureAlpha(), fmdb_d.getFeatureAlpha());
  task.setLambda(lambda);
  for (unsigned int k = 0; k < steps; ++k) {
    seen = project(object, cMo);
    src.fromVector(seen);
    plane_abc(cMo, A, B, C);
    mdb.updateAll(src);
    fmdb.updateAll(A, B, C);
    vpColVector v = task.computeControlLaw();
    cMo = vpExponentialMap::direct(v, dt).inverse() * cMo;  // the camera moved by v over dt
    for (unsigned int i = 0; i < 3; ++i)
      for (unsigned int j = 0; j < 3; ++j)
        put(out, cMo[i][j]);
    for (unsigned int i = 0; i < 3; ++i)
      put(out, cMo[i][3]);
  }
}
} // namespace

int main()
{
  std::cout.precision(17);
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string what;
    in >> what;
    std::ostringstream out;
    out.precision(17);
    out << what;
    if (what == "moments")
      moments(in, out);
    else if (what == "polar")
      polar(in, out);
    else if (what == "servo")
      servo(in, out);
    else {
      std::cerr << "unknown request: " << what << std::endl;
      return 2;
    }
    std::cout << out.str() << std::endl;
  }
  return 0;
}
