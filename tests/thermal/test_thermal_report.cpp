// io/thermal_report: the thermal fit's report.html. A hand-made fit with one hysteretic
// coefficient and heating, cooling and soaked points: one plot per coefficient, the branches
// only where the coefficient has a dT/dt term, each point in its shape, the calibrated range
// and its extrapolation flag, nothing fetched from the network; a DIR that cannot be created is
// named.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/thermal_report.h"

namespace imubench::io {
namespace {

namespace m = calib::model;

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

// The plots in order (the text between "<svg" and "</svg>").
std::vector<std::string> plots(const std::string& html) {
  std::vector<std::string> out;
  for (std::size_t p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) {
    out.push_back(html.substr(p, html.find("</svg>", p) - p));
  }
  return out;
}

calib::ThermalRunsFitResult exampleFit() {
  calib::ThermalRunsFitResult r;
  r.status = r.fit.status = calib::FitStatus();
  m::ThermalCoefficients& c = r.fit.coefficients;
  c.t_ref_c = 20.0;
  c.t_min_c = 5.0;
  c.t_max_c = 35.0;
  for (int i = 0; i < m::kTriadSize; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    c.accel[k].order = c.gyro[k].order = 1;
    c.accel[k].poly = {i < 3 ? 1.0 : 1e-3, 1e-5, 0, 0, 0};
    c.gyro[k].poly = {i < 3 ? 1.0 : 1e-6, 1e-8, 0, 0, 0};
    c.accel[k].sigma_poly = {1e-6, 1e-8, 0, 0, 0};
    c.gyro[k].sigma_poly = {1e-9, 1e-11, 0, 0, 0};
    r.fit.fits.push_back({calib::thermalCoefficientName("accel", i), 3, 3.0, 0.0, 1.0});
  }
  for (int i = 0; i < m::kTriadSize; ++i) {
    r.fit.fits.push_back({calib::thermalCoefficientName("gyro", i), 3, 3.0, 0.0, 1.0});
  }
  c.accel[m::kBias].hysteresis = true;  // accel.bias.x: heating and cooling differ
  c.accel[m::kBias].dTdt = 2e-3;
  c.accel[m::kBias].sigma_dTdt = 1e-4;
  for (const auto& [temp, rate] : {std::pair{8.0, 0.05}, {20.0, 0.0}, {32.0, -0.05}}) {
    calib::ThermalFitPoint p;
    p.temp_c = temp;
    p.temp_rate = rate;
    for (std::size_t k = 0; k < m::kTriadSize; ++k) {
      p.accel[k] = m::thermalValue(c.accel[k], temp - 20.0, rate);
      p.gyro[k] = m::thermalValue(c.gyro[k], temp - 20.0, rate);
      p.sigma_accel[k] = 2e-6;
      p.sigma_gyro[k] = 2e-9;
      p.observable_accel[k] = p.observable_gyro[k] = true;
    }
    r.points.push_back(p);
  }
  return r;
}

TEST(ThermalReport, PlotPerCoefficientBranchesPointsAndRange) {
  ThermalReportOptions o;
  o.title = "runs 1, 2";
  o.method = "points";
  const std::string html = thermalReportHtml(exampleFit(), o);
  EXPECT_EQ(html.find("http"), std::string::npos) << "not self-contained";
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_NE(html.find("Calibrated range: 5.00 .. 35.00 degC."), std::string::npos);
  EXPECT_NE(html.find("Outside it the model extrapolates"), std::string::npos);
  // The branches at the points' typical rate: 0.05 degC/s = 3 degC/min.
  EXPECT_NE(html.find("&plusmn;3 degC/min"), std::string::npos);
  const std::vector<std::string> p = plots(html);
  ASSERT_EQ(p.size(), 24u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    SCOPED_TRACE(i);
    const bool hysteretic = i == static_cast<std::size_t>(m::kBias);
    EXPECT_EQ(count(p[i], "stroke-dasharray='6,3'"), hysteretic ? 2 : 0);  // branches
    EXPECT_EQ(count(p[i], "<polygon fill='#c0392b'"), 1);                  // heating point
    EXPECT_EQ(count(p[i], "<polygon fill='#1f5fbf'"), 1);                  // cooling point
    EXPECT_EQ(count(p[i], "<circle"), 1);                                  // soaked point
    EXPECT_EQ(count(p[i], "extrapolated (held)"), 2);                      // range edges
  }
  EXPECT_NE(html.find("<h3>accel.bias.x (order 1, dT/dt term)</h3>"), std::string::npos);
  EXPECT_NE(html.find("<h3>gyro.misalignment.zy (order 1)</h3>"), std::string::npos);
}

TEST(ThermalReport, WritesReportHtmlAndNamesABadDirectory) {
  const std::filesystem::path base = std::filesystem::temp_directory_path() /
                                     ("imubench_thermal_report_" + std::to_string(::getpid()));
  std::filesystem::remove_all(base);
  ThermalReportOptions o;
  o.method = "joint";
  ASSERT_TRUE(writeThermalReport((base / "rep").string(), exampleFit(), o).ok);
  std::ifstream in(base / "rep" / "report.html");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(plots(text.str()).size(), 24u);
  std::ofstream(base / "file") << "x";
  const std::string bad = (base / "file" / "rep").string();
  const Status st = writeThermalReport(bad, exampleFit(), o);
  EXPECT_FALSE(st.ok);
  EXPECT_NE(st.message.find(bad), std::string::npos) << st.message;
  std::filesystem::remove_all(base);
}

}  // namespace
}  // namespace imubench::io
