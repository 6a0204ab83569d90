// src/sweep/report.cpp — see report.h. (Placeholder until the report lands: writes a
// minimal index.html that lists sweep.csv.)
#include "sweep/report.h"

#include <filesystem>
#include <fstream>

#include "tessref/error.h"

namespace tessref::sweep {

void write_sweep_report(const std::string& dir) {
    const std::filesystem::path csv = std::filesystem::path(dir) / "sweep.csv";
    if (!std::filesystem::exists(csv)) throw Error("no sweep.csv in the sweep directory", Where::in_file(csv.string()));
    std::ofstream out(std::filesystem::path(dir) / "index.html");
    out << "<!doctype html><meta charset=utf-8><title>tessref sweep</title><p><a href=\"sweep.csv\">sweep.csv</a>\n";
}

}  // namespace tessref::sweep
