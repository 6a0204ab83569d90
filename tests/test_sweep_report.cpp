// Tests of the sweep report (src/sweep/report.h) and the rules behind it (report_data.h).
//
// Where the expected values come from:
//  - the Pareto front and the "stops improving" level: small point sets and error curves
//    whose answers are derived by hand in the comments beside them;
//  - the report: hand-made sweep.csv files in a fresh directory, the outputs read back (the
//    HTML's links resolved against the directory, the SVG's tags balanced, the PNG opened
//    with OpenImageIO and its size checked against the SVG's);
//  - determinism: the same table twice, and its rows shuffled (merged shards), compared
//    byte for byte;
//  - malformed tables: each must be a tessref::Error naming sweep.csv and the line.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "command_dir_test.h"
#include "sweep/plot.h"
#include "sweep/report.h"
#include "sweep/report_data.h"
#include "tessref/error.h"

namespace fs = std::filesystem;
using tessref::Error;
using tessref::sweep::CostError;
using tessref::sweep::LevelError;

namespace {

std::string read_text(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
}

// ---------------------------------------------------------------------------------------
// The rules

TEST(SweepReportRules, ParetoFrontHandDerived) {
    const std::vector<CostError> points{
        {1, 5},  // 0: the cheapest: nothing costs <= 1 with less error -> front
        {2, 3},  // 1: only (1,5) is as cheap or cheaper, and it has more error -> front
        {3, 3},  // 2: (2,3) costs less with the same error -> dominated
        {4, 1},  // 3: the least error, and the cheapest with it -> front
        {2, 4},  // 4: (2,3) costs the same with less error -> dominated
        {5, 1},  // 5: (4,1) costs less with the same error -> dominated
        {1, 5},  // 6: equal to point 0; equal points do not dominate each other -> front
    };
    const std::vector<bool> expected{true, true, false, true, false, false, true};
    EXPECT_EQ(tessref::sweep::pareto_front(points), expected);
    EXPECT_TRUE(tessref::sweep::pareto_front({}).empty());
    const std::vector<CostError> one{{7, 7}};
    EXPECT_EQ(tessref::sweep::pareto_front(one), std::vector<bool>{true});
}

TEST(SweepReportRules, StopImprovingLevelHandDerived) {
    using tessref::sweep::stop_improving_level;
    // Minimum m = 0.0300 (levels 16 and 64); tolerance max(1% of m = 0.0003, 0.5/255 =
    // 0.00196) = 0.00196, so the floor is 0.03196: level 4 (0.05) is above it, level 8
    // (0.0302) the first below. The curve is given out of order on purpose.
    const std::vector<LevelError> absolute{{64, 0.0300}, {1, 0.20}, {2, 0.10}, {4, 0.05},
                                           {8, 0.0302},  {16, 0.0300}, {32, 0.0301}};
    EXPECT_EQ(stop_improving_level(absolute), 8);
    // Large errors: m = 0.30, 1% of m = 0.003 beats 0.5/255, floor 0.303: level 2 (0.31) is
    // above, level 3 (0.3025) below.
    const std::vector<LevelError> relative{{1, 0.5}, {2, 0.31}, {3, 0.3025}, {4, 0.30}};
    EXPECT_EQ(stop_improving_level(relative), 3);
    // Not monotonic: level 2 already reaches the floor (0.01 + 0.00196) even though level 3
    // is worse again.
    const std::vector<LevelError> bumpy{{1, 0.1}, {2, 0.0110}, {3, 0.05}, {4, 0.0100}};
    EXPECT_EQ(stop_improving_level(bumpy), 2);
    EXPECT_EQ(stop_improving_level({}), std::nullopt);
    EXPECT_DOUBLE_EQ(tessref::sweep::stop_tolerance(0.0), 0.5 / 255.0);
    EXPECT_DOUBLE_EQ(tessref::sweep::stop_tolerance(1.0), 0.01);
}

// The budget rule: the least error among the levels that fit the budget, the smaller level
// on a tie; and the dominance of the scene's own levels: the cheapest uniform level with no
// more triangles and no more error, one of the two strictly less.
TEST(SweepReportRules, BestLevelUnderBudgetAndDominatingLevelHandDerived) {
    using tessref::sweep::LevelRun;
    const std::vector<LevelRun> runs{
        {8, 2048, 0.030},  // out of order on purpose
        {1, 32, 0.200},
        {2, 128, 0.100},
        {4, 512, 0.030},   // ties level 8's error with fewer triangles
        {16, 8192, 0.020},
    };
    using tessref::sweep::best_level_under_budget;
    EXPECT_EQ(best_level_under_budget(runs, 8192), 16);  // everything fits: the least error
    EXPECT_EQ(best_level_under_budget(runs, 8191), 4);   // 4 and 8 tie at 0.030: the smaller
    EXPECT_EQ(best_level_under_budget(runs, 511), 2);
    EXPECT_EQ(best_level_under_budget(runs, 32), 1);     // the budget itself fits
    EXPECT_EQ(best_level_under_budget(runs, 31), std::nullopt);
    EXPECT_EQ(best_level_under_budget({}, 1e9), std::nullopt);

    using tessref::sweep::dominating_level;
    // Own levels at 3000 triangles, error 0.04: level 4 (512, 0.030) is the cheapest that
    // beats it on both (level 8 does too).
    EXPECT_EQ(dominating_level(runs, {0, 3000, 0.04}), 4);
    // Error 0.030 at 512 triangles: level 4 is equal on both, which is not dominance; level 8
    // costs more. None.
    EXPECT_EQ(dominating_level(runs, {0, 512, 0.030}), std::nullopt);
    // Error 0.030 at 600 triangles: level 4 has fewer triangles and the same error: dominates.
    EXPECT_EQ(dominating_level(runs, {0, 600, 0.030}), 4);
    // A better error than any level within its triangles: not dominated.
    EXPECT_EQ(dominating_level(runs, {0, 100, 0.15}), std::nullopt);
}

TEST(SweepReportRules, GpuExactRatio) {
    // Shared levels 1 and 2: ratios 0.2/0.1 = 2 and 0.1/0.1 = 1 -> median 1.5.
    const std::vector<LevelError> gpu{{1, 0.2}, {2, 0.1}, {4, 0.06}};
    const std::vector<LevelError> exact{{1, 0.1}, {2, 0.1}, {8, 0.05}};
    const tessref::sweep::ErrorRatio r = tessref::sweep::gpu_exact_ratio(gpu, exact);
    EXPECT_EQ(r.levels, 2u);
    EXPECT_DOUBLE_EQ(r.median, 1.5);
    EXPECT_DOUBLE_EQ(r.min, 1.0);
    EXPECT_DOUBLE_EQ(r.max, 2.0);
    EXPECT_EQ(tessref::sweep::gpu_exact_ratio(gpu, std::vector<LevelError>{{16, 0.1}}).levels, 0u);
}

// ---------------------------------------------------------------------------------------
// Hand-made sweep tables

const std::vector<std::string> kHeader{
    "scene", "model", "level", "spacing", "precision", "patches", "triangles", "points", "control_ms",
    "generator_ms", "evaluation_ms", "geometry_ms", "raster_shading_ms", "total_ms", "geo_max", "geo_rms",
    "geo_max_px", "img_rmse", "img_psnr", "img_fail_px", "gpu_exact_max_pos", "gpu_exact_image_differs", "image",
    "diff_image", "wire_image", "truth_image", "a_future_column"};

std::string join(const std::vector<std::string>& fields) {
    std::string line;
    for (std::size_t i = 0; i < fields.size(); ++i) line += (i ? "," : "") + fields[i];
    return line;
}

// One row; columns not given are empty.
std::string row(const std::map<std::string, std::string>& cells) {
    std::vector<std::string> fields;
    for (const std::string& name : kHeader) {
        const auto it = cells.find(name);
        fields.push_back(it == cells.end() ? "" : it->second);
    }
    return join(fields);
}

std::string uniform(const std::string& scene, const std::string& precision, int level, const std::string& rmse,
                    const std::string& extra_picture = "") {
    std::map<std::string, std::string> cells{
        {"scene", scene},          {"model", "uniform"},  {"level", std::to_string(level)},
        {"spacing", "fractional_odd"}, {"precision", precision}, {"patches", "16"},
        {"triangles", std::to_string(32 * level * level)},  {"points", std::to_string(17 * level * level)},
        {"total_ms", std::to_string(level) + ".5"},        {"geo_max", "0.01"}, {"img_rmse", rmse},
        {"img_psnr", "inf"},       {"img_fail_px", "3"},    {"control_ms", "0.1"}, {"a_future_column", "x"}};
    if (!extra_picture.empty()) {
        cells["image"] = "images/" + extra_picture + ".png";
        cells["diff_image"] = "images/" + extra_picture + "-diff.png";
        cells["wire_image"] = "images/" + extra_picture + "-wire.png";
        cells["truth_image"] = "images/" + scene + "-truth.png";
    }
    return row(cells);
}

// alpha: gpu and exact at levels 1, 2, 4, 8, 16 plus its own model; beta: gpu at 1 and 4.
//  alpha gpu:   0.2, 0.1, 0.05, 0.0302, 0.03 -> stops improving at 8 (floor 0.03196)
//  alpha exact: 0.1, 0.05, 0.021, 0.0201, 0.02 -> stops improving at 4 (floor 0.02196)
//  gpu/exact:   2, 2, 2.381, 1.5025, 1.5 -> median 2, from 1.5 to 2.381
//  beta gpu:    0.4, 0.001 -> stops improving at 4
std::vector<std::string> sample_rows() {
    return {
        uniform("alpha", "gpu", 1, "0.2"),
        uniform("alpha", "gpu", 2, "0.1"),
        uniform("alpha", "gpu", 4, "0.05", "alpha-gpu-L4"),
        uniform("alpha", "gpu", 8, "0.0302"),
        uniform("alpha", "gpu", 16, "0.03"),
        uniform("alpha", "exact", 1, "0.1"),
        uniform("alpha", "exact", 2, "0.05"),
        uniform("alpha", "exact", 4, "0.021"),
        uniform("alpha", "exact", 8, "0.0201"),
        uniform("alpha", "exact", 16, "0.02"),
        row({{"scene", "alpha"}, {"model", "distance"}, {"spacing", "fractional_odd"}, {"precision", "gpu"},
             {"triangles", "3000"}, {"total_ms", "3.25"}, {"img_rmse", "0.04"}}),
        uniform("beta", "gpu", 1, "0.4"),
        uniform("beta", "gpu", 4, "0.001", "beta-gpu-L4"),
    };
}

std::string table(const std::vector<std::string>& rows) {
    std::string text = join(kHeader) + "\n";
    for (const std::string& r : rows) text += r + "\n";
    return text;
}

class SweepReport : public tessref::test::CommandDirTest {
protected:
    fs::path csv() const { return dir() / "sweep.csv"; }
    const fs::path& dir() const { return dir_; }

    // Writes sweep.csv and placeholder pictures for every picture path it names.
    void make_sweep(const std::vector<std::string>& rows) {
        write_text(csv(), table(rows));
        for (const std::string& name : {"alpha-gpu-L4", "alpha-gpu-L4-diff", "alpha-gpu-L4-wire", "alpha-truth",
                                        "beta-gpu-L4", "beta-gpu-L4-diff", "beta-gpu-L4-wire", "beta-truth"})
            write_text(dir() / "images" / (name + ".png"), "picture");
    }

    // The error write_sweep_report throws for this sweep.csv text.
    Error error_for(const std::string& text) {
        write_text(csv(), text);
        try {
            tessref::sweep::write_sweep_report(dir().string());
        } catch (const Error& e) {
            EXPECT_FALSE(fs::exists(dir() / "index.html")) << "a failed report wrote index.html";
            return e;
        }
        ADD_FAILURE() << "no error for:\n" << text;
        return Error("none");
    }
};

std::vector<std::string> attribute_values(const std::string& html, const std::string& attribute) {
    std::vector<std::string> values;
    const std::regex pattern(attribute + "=\"([^\"]*)\"");
    for (auto it = std::sregex_iterator(html.begin(), html.end(), pattern); it != std::sregex_iterator(); ++it)
        values.push_back((*it)[1].str());
    return values;
}

// Element tags balanced (self-closing ones aside) and properly nested.
bool balanced_xml(const std::string& xml) {
    std::vector<std::string> open;
    const std::regex tag("<(/?)([a-zA-Z][a-zA-Z0-9]*)[^>]*?(/?)>");
    for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator(); ++it) {
        const std::string name = (*it)[2].str();
        if ((*it)[3].length()) continue;  // <x/>
        if ((*it)[1].length()) {
            if (open.empty() || open.back() != name) return false;
            open.pop_back();
        } else {
            open.push_back(name);
        }
    }
    return open.empty();
}

TEST_F(SweepReport, WritesPlotsAndAPageThatNeedsNoNetwork) {
    make_sweep(sample_rows());
    tessref::sweep::write_sweep_report(dir().string());

    const std::string html = read_text(dir() / "index.html");
    EXPECT_EQ(html.find("http://"), std::string::npos);
    EXPECT_EQ(html.find("https://"), std::string::npos);
    EXPECT_TRUE(balanced_xml(html.substr(html.find("<html"))));
    // Every link resolves inside the directory (the pictures exist: make_sweep wrote them).
    std::vector<std::string> links = attribute_values(html, "href");
    const std::vector<std::string> sources = attribute_values(html, "src");
    links.insert(links.end(), sources.begin(), sources.end());
    EXPECT_GE(links.size(), 10u);
    for (const std::string& link : links) {
        if (link.starts_with("#")) {
            EXPECT_NE(html.find("id=\"" + link.substr(1) + "\""), std::string::npos) << link;
            continue;
        }
        EXPECT_FALSE(link.starts_with("/")) << link;
        EXPECT_TRUE(fs::is_regular_file(dir() / link)) << link;
    }
    // The rules' answers, as the table comment derives them.
    EXPECT_NE(html.find("In <b>alpha</b> the image error stops improving at <b>level 4</b> (fractional_odd exact) "
                        "and at <b>level 8</b> (fractional_odd gpu)."),
              std::string::npos);
    EXPECT_NE(html.find("In <b>beta</b> the image error stops improving at <b>level 4</b> (fractional_odd gpu)."),
              std::string::npos);
    EXPECT_NE(html.find("median 2 (from 1.5 to 2.381) over the 5 levels both ran"), std::string::npos);
    EXPECT_NE(html.find("0.5/255"), std::string::npos);  // the rule is stated
    // The truth once per scene; no timing anywhere.
    std::size_t truths = 0;
    for (std::size_t at = 0; (at = html.find("src=\"images/alpha-truth.png\"", at)) != std::string::npos; ++at)
        ++truths;
    EXPECT_EQ(truths, 1u);
    EXPECT_EQ(html.find("total_ms"), std::string::npos);

    for (const char* name : {"error-vs-time", "error-vs-triangles"}) {
        const std::string svg = read_text(dir() / "plots" / (std::string(name) + ".svg"));
        ASSERT_TRUE(svg.starts_with("<svg")) << name;
        EXPECT_TRUE(svg.ends_with("</svg>\n")) << name;
        EXPECT_TRUE(balanced_xml(svg)) << name;
        EXPECT_NE(svg.find("Pareto front"), std::string::npos);
        const std::smatch size = [&] {
            std::smatch m;
            std::regex_search(svg, m, std::regex("width=\"([0-9]+)\" height=\"([0-9]+)\""));
            return m;
        }();
        ASSERT_EQ(size.size(), 3u);

        const std::string png = (dir() / "plots" / (std::string(name) + ".png")).string();
        auto in = OIIO::ImageInput::open(png);
        ASSERT_TRUE(in) << png;
        EXPECT_EQ(in->spec().width, std::stoi(size[1].str()));
        EXPECT_EQ(in->spec().height, std::stoi(size[2].str()));
        EXPECT_EQ(in->spec().nchannels, 4);
        std::vector<unsigned char> pixels(static_cast<std::size_t>(in->spec().width) * in->spec().height * 4);
        ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeDesc::UINT8, pixels.data()));
        // Not blank: some pixels are painted in the first series' colour.
        const auto c = tessref::sweep::series_colour(0).codes();
        bool painted = false;
        for (std::size_t i = 0; i < pixels.size() && !painted; i += 4)
            painted = pixels[i] == c[0] && pixels[i + 1] == c[1] && pixels[i + 2] == c[2];
        EXPECT_TRUE(painted) << png;
    }
    // The fronts through the whole pipeline, one ring per front point plus the legend's.
    //  triangles: alpha's exact runs (32, 0.1) ... (8192, 0.02) each beat the gpu run of the
    //  same level, and its own levels (3000, 0.04) lose to exact level 8 (2048, 0.0201): 5;
    //  beta: both points: 2. Total 7.
    //  time (level + 0.5 ms, own 3.25 ms): alpha's 5 exact runs and its own levels, which no
    //  faster run matches (exact level 2 at 2.5 ms has 0.05 > 0.04): 6; beta: 2. Total 8.
    auto rings = [&](const char* name) {
        const std::string svg = read_text(dir() / "plots" / name);
        std::size_t n = 0;
        for (std::size_t at = 0; (at = svg.find("fill=\"none\"", at)) != std::string::npos; ++at) ++n;
        return n;
    };
    EXPECT_EQ(rings("error-vs-triangles.svg"), 7u + 1u);
    EXPECT_EQ(rings("error-vs-time.svg"), 8u + 1u);
    // No temporary files left behind.
    for (const auto& entry : fs::recursive_directory_iterator(dir()))
        EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

// The advice, derived by hand from sample_rows():
//  alpha gpu: the knee is level 8 (see above); the own levels draw 3000 triangles, so levels
//  1, 2, 4, 8 (32 L^2 triangles) fit and level 8 has the least error among them (0.0302);
//  it also dominates the own levels (2048 < 3000 triangles, 0.0302 < 0.04), and no smaller
//  level does (level 4's 0.05 is worse). alpha exact: knee 4, no own row, so no budget.
//  The plots label every point with its level and say whose time they plot.
TEST_F(SweepReport, RecommendsLevelsByStatedRulesAndLabelsThePoints) {
    make_sweep(sample_rows());
    tessref::sweep::write_sweep_report(dir().string());
    const std::string html = read_text(dir() / "index.html");
    EXPECT_NE(html.find("<li>fractional_odd spacing, gpu precision: <b>level 8</b>, the knee (img_rmse 0.0302, 2048 "
                        "triangles): the least image error is 0.03 at level 16, and level 8 is the smallest within "
                        "0.001961 of it; under the triangle budget of the scene's own levels (3000), <b>level 8</b> "
                        "(img_rmse 0.0302, 2048 triangles).</li>"),
              std::string::npos)
        << html;
    EXPECT_NE(html.find("<li>fractional_odd spacing, exact precision: <b>level 4</b>, the knee (img_rmse 0.021, 512 "
                        "triangles): the least image error is 0.02 at level 16, and level 4 is the smallest within "
                        "0.001961 of it.</li>"),
              std::string::npos);
    EXPECT_NE(html.find("The scene's own control stage (distance) is dominated with fractional_odd spacing, gpu "
                        "precision: uniform level 8 draws fewer triangles (2048 against 3000) with a lower image "
                        "error (0.0302 against 0.04)."),
              std::string::npos);
    EXPECT_EQ(html.find("own control stage (distance) is dominated with fractional_odd spacing, exact"), std::string::npos);
    // beta has a picture at its knee, level 4, and says so.
    EXPECT_NE(html.find("fractional_odd spacing, gpu precision, level 4 (recommended: the knee): img_rmse 0.001"),
              std::string::npos);
    for (const char* name : {"error-vs-time.svg", "error-vs-triangles.svg"}) {
        const std::string svg = read_text(dir() / "plots" / name);
        for (const char* label : {">1<", ">2<", ">4<", ">8<", ">16<", ">own<"})
            EXPECT_NE(svg.find(label), std::string::npos) << name << " " << label;
    }
    EXPECT_NE(read_text(dir() / "plots" / "error-vs-time.svg").find("tessref&#39;s CPU reference, not a GPU&#39;s"),
              std::string::npos);
}

TEST_F(SweepReport, SameTableSameBytesWhateverTheRowOrder) {
    make_sweep(sample_rows());
    tessref::sweep::write_sweep_report(dir().string());
    const std::vector<std::string> names{"index.html", "plots/error-vs-time.svg", "plots/error-vs-time.png",
                                         "plots/error-vs-triangles.svg", "plots/error-vs-triangles.png"};
    std::vector<std::string> first;
    for (const std::string& name : names) first.push_back(read_text(dir() / name));

    tessref::sweep::write_sweep_report(dir().string());
    for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(read_text(dir() / names[i]), first[i]) << names[i];

    // Shards merged in another order: the same report.
    std::vector<std::string> rows = sample_rows();
    std::reverse(rows.begin(), rows.end());
    std::rotate(rows.begin(), rows.begin() + 5, rows.end());
    write_text(csv(), table(rows));
    tessref::sweep::write_sweep_report(dir().string());
    for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(read_text(dir() / names[i]), first[i]) << names[i];
}

TEST_F(SweepReport, MalformedTablesNameFileAndLine) {
    const std::string path = csv().string();
    auto expect_at = [&](const Error& e, int line, const std::string& says) {
        EXPECT_EQ(e.where().file, path);
        EXPECT_EQ(e.where().line, line) << e.message();
        EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.message();
    };
    const std::string header = join(kHeader) + "\n";
    const std::string good = uniform("alpha", "gpu", 1, "0.2") + "\n";

    // A failing report leaves the previous one as it was.
    make_sweep(sample_rows());
    tessref::sweep::write_sweep_report(dir().string());
    const std::string previous = read_text(dir() / "index.html");
    write_text(csv(), header + good + "alpha,uniform,2\n");
    EXPECT_THROW(tessref::sweep::write_sweep_report(dir().string()), Error);
    EXPECT_EQ(read_text(dir() / "index.html"), previous);
    fs::remove(dir() / "index.html");

    expect_at(error_for(""), 1, "empty");
    expect_at(error_for(header + good + "alpha,uniform,2\n"), 3, "fields");
    expect_at(error_for(header + good + good.substr(0, good.size() - 1) + ",extra\n"), 3, "fields");
    expect_at(error_for(header + uniform("alpha", "gpu", 1, "0.2x") + "\n"), 2, "not a number");
    expect_at(error_for(header + good + uniform("\"alpha\"", "gpu", 2, "0.2") + "\n"), 3, "quote");
    expect_at(error_for(header + uniform("alpha", "gpu", 1, "nan") + "\n"), 2, "not a finite number");
    expect_at(error_for(header + uniform("alpha", "gpu", 1, "inf") + "\n"), 2, "not a finite number");
    expect_at(error_for(header + uniform("alpha", "gpu", 1, "-1") + "\n"), 2, "finite number");
    expect_at(error_for(header + uniform("alpha", "gpu", 0, "0.2") + "\n"), 2, "[1, 64]");
    expect_at(error_for(header + uniform("alpha", "gpu", 65, "0.2") + "\n"), 2, "[1, 64]");
    expect_at(error_for(header + good + good), 3, "same run as line 2");
    expect_at(error_for(header + good + "\n" + uniform("alpha", "gpu", 2, "0.1") + "\n"), 3, "blank line");
    {
        std::vector<std::string> no_rmse = kHeader;
        no_rmse.erase(std::find(no_rmse.begin(), no_rmse.end(), "img_rmse"));
        expect_at(error_for(join(no_rmse) + "\n"), 1, "img_rmse");
    }
    expect_at(error_for(header + row({{"scene", "alpha"}, {"model", "uniform"}, {"spacing", "equal"},
                                       {"precision", "gpu"}, {"img_rmse", "0.1"}}) + "\n"),
              2, "needs a level");
    expect_at(error_for(header + row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "1"}, {"spacing", "equal"},
                                       {"precision", "gpu"}, {"image", "../outside.png"}}) + "\n"),
              2, "relative path");
    expect_at(error_for(header + row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "1"}, {"spacing", "equal"},
                                       {"precision", "gpu"}, {"image", "/etc/x.png"}}) + "\n"),
              2, "relative path");
    // The column is named too.
    const Error e = error_for(header + uniform("alpha", "gpu", 1, "abc") + "\n");
    EXPECT_EQ(e.where().key, "img_rmse");
    EXPECT_NE(e.message().find("sweep.csv:2"), std::string::npos) << e.message();

    fs::remove(csv());
    EXPECT_THROW(tessref::sweep::write_sweep_report(dir().string()), Error);
}

TEST_F(SweepReport, CameraRelativeColumnSplitsSeries) {
    // Two series that differ only in camera_relative; both reach their floor at level 2
    // (0.0505 <= 0.05 + 0.00196 and 0.0201 <= 0.02 + 0.00196; level 1 is far above).
    std::string text = join(kHeader) + ",camera_relative\n";
    text += uniform("alpha", "gpu", 1, "0.2") + ",0\n";
    text += uniform("alpha", "gpu", 2, "0.0505") + ",0\n";
    text += uniform("alpha", "gpu", 3, "0.05") + ",0\n";
    text += uniform("alpha", "gpu", 1, "0.1") + ",1\n";
    text += uniform("alpha", "gpu", 2, "0.0201") + ",1\n";
    text += uniform("alpha", "gpu", 3, "0.02") + ",1\n";
    write_text(csv(), text);
    tessref::sweep::write_sweep_report(dir().string());
    const std::string html = read_text(dir() / "index.html");
    EXPECT_NE(html.find("stops improving at <b>level 2</b> with every spacing and precision it ran."),
              std::string::npos);
    EXPECT_NE(html.find("<td class=t>camera-relative</td>"), std::string::npos);
    EXPECT_NE(read_text(dir() / "plots/error-vs-triangles.svg").find("alpha fractional_odd gpu camera-relative"),
              std::string::npos);
    // A camera_relative cell other than 0 or 1 is an error on its line.
    write_text(csv(), join(kHeader) + ",camera_relative\n" + uniform("alpha", "gpu", 1, "0.2") + ",yes\n");
    try {
        tessref::sweep::write_sweep_report(dir().string());
        ADD_FAILURE() << "camera_relative 'yes' accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.where().line, 2);
    }
}

TEST_F(SweepReport, FractionalLevelsAndNonFiniteMeasurements) {
    // The sweep writes levels with "%.9g" (2.5 is a level) and nan / inf where a measurement
    // has no finite value. Floor 0.03 + 0.00196: level 1 (0.2) above, level 2.5 (0.0301) below.
    std::string text = join(kHeader) + "\n";
    text += row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "1"}, {"spacing", "equal"}, {"precision", "gpu"},
                 {"triangles", "10"}, {"total_ms", "1"}, {"img_rmse", "0.2"}, {"geo_max", "nan"}}) + "\n";
    text += row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "2.5"}, {"spacing", "equal"}, {"precision", "gpu"},
                 {"triangles", "40"}, {"total_ms", "2"}, {"img_rmse", "0.0301"}, {"img_psnr", "inf"}}) + "\n";
    text += row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "4"}, {"spacing", "equal"}, {"precision", "gpu"},
                 {"triangles", "90"}, {"total_ms", "3"}, {"img_rmse", "0.03"}}) + "\n";
    // No triangles: on the curve, but with no place on the triangles' log axis.
    text += row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "8"}, {"spacing", "equal"}, {"precision", "gpu"},
                 {"triangles", "0"}, {"total_ms", "4"}, {"img_rmse", "0.03"}}) + "\n";
    write_text(csv(), text);
    tessref::sweep::write_sweep_report(dir().string());
    const std::string html = read_text(dir() / "index.html");
    EXPECT_NE(html.find("stops improving at <b>level 2.5</b> (equal gpu)."), std::string::npos);
    EXPECT_NE(html.find("<td>nan</td>"), std::string::npos);
    EXPECT_NE(html.find("<td>inf</td>"), std::string::npos);
    EXPECT_NE(read_text(dir() / "plots/error-vs-triangles.svg")
                  .find("1 run without img_rmse or with triangles 0 left out"),
              std::string::npos);
    EXPECT_EQ(read_text(dir() / "plots/error-vs-time.svg").find("left out"), std::string::npos);
}

// A geomipmapped scene's rows: level 0..4 on geomip_level rows, a bound >= 0 in pixels on
// geomip_bound rows, an empty spacing (no generator). The report reads them, shows them as
// their own series and says that the uniform-level rules do not apply; out-of-range levels
// and bounds, and an empty spacing on another scene's row, are refused naming the line.
TEST_F(SweepReport, GeomipRowsReadAndShown) {
    const auto geo = [](const std::string& model, const std::string& level, const std::string& triangles,
                        const std::string& rmse) {
        return row({{"scene", "geo"}, {"model", model}, {"level", level}, {"spacing", ""}, {"precision", "gpu"},
                    {"patches", "4"}, {"triangles", triangles}, {"total_ms", "1.5"}, {"geo_max", "0.5"},
                    {"img_rmse", rmse}});
    };
    std::vector<std::string> rows = sample_rows();
    for (const std::string& r : {geo("geomipmap", "", "600", "0.03"), geo("geomip_level", "0", "2048", "0.004"),
                                 geo("geomip_level", "2", "128", "0.05"), geo("geomip_level", "4", "8", "0.09"),
                                 geo("geomip_bound", "0", "2048", "0.004"), geo("geomip_bound", "0.5", "1500", "0.01"),
                                 geo("geomip_bound", "8", "8", "0.09")})
        rows.push_back(r);
    make_sweep(rows);
    const tessref::sweep::SweepTable t = tessref::sweep::read_sweep_csv(csv().string());
    std::vector<std::string> geo_order;
    for (const auto& r : t.rows)
        if (r.scene == "geo") geo_order.push_back(r.model + " " + (r.level ? std::to_string(*r.level) : "-"));
    const std::vector<std::string> expected{"geomipmap -",          "geomip_level 0.000000", "geomip_level 2.000000",
                                            "geomip_level 4.000000", "geomip_bound 0.000000", "geomip_bound 0.500000",
                                            "geomip_bound 8.000000"};
    EXPECT_EQ(geo_order, expected);
    tessref::sweep::write_sweep_report(dir().string());
    const std::string index = read_text(dir() / "index.html");
    EXPECT_NE(index.find("is a geomipmapped terrain"), std::string::npos);
    EXPECT_NE(index.find("geomip L4"), std::string::npos);
    EXPECT_NE(index.find("bound 0.5 px"), std::string::npos);
    const std::string plot = read_text(dir() / "plots/error-vs-triangles.svg");
    EXPECT_NE(plot.find("geo gpu geomip_bound"), std::string::npos);  // plot series of their own
    EXPECT_NE(plot.find("geo gpu geomip_level"), std::string::npos);
    // The other scenes' verdicts are unchanged by the geomip rows.
    EXPECT_NE(index.find("stops improving"), std::string::npos);

    fs::remove(dir() / "index.html");  // error_for checks that a failed report writes none
    const std::string header = join(kHeader) + "\n";
    const auto says = [&](const std::string& line, const std::string& what) {
        const Error e = error_for(header + line + "\n");
        EXPECT_EQ(e.where().line, 2) << e.message();
        EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.message();
    };
    says(geo("geomip_level", "5", "8", "0.1"), "0..4");
    says(geo("geomip_level", "1.5", "8", "0.1"), "0..4");
    says(geo("geomip_bound", "-1", "8", "0.1"), "bound");
    says(geo("geomip_bound", "", "8", "0.1"), "needs a level");
    says(row({{"scene", "alpha"}, {"model", "uniform"}, {"level", "1"}, {"spacing", ""}, {"precision", "gpu"},
              {"triangles", "2"}, {"total_ms", "1"}, {"img_rmse", "0.1"}}),
         "spacing");
}

TEST_F(SweepReport, EmptyTableStillMakesAPage) {
    write_text(csv(), join(kHeader) + "\n");
    tessref::sweep::write_sweep_report(dir().string());
    EXPECT_TRUE(fs::is_regular_file(dir() / "index.html"));
    EXPECT_TRUE(read_text(dir() / "plots/error-vs-time.svg").starts_with("<svg"));
}

}  // namespace
