// src/sweep/report.h — the speed/accuracy report of a sweep directory.
//
// `tessref sweep` (src/cli/cmd_sweep.cpp, src/sweep/sweep.cpp) writes DIR/sweep.csv (one
// header line, one row per run; the columns are documented in docs/SWEEP.md) and the
// pictures its rows name under DIR/images/. write_sweep_report() reads only those, so the
// report of a merged set of shards is made exactly as the report of one unsharded run:
//
//   DIR/plots/error-vs-time.{svg,png}       image error against time, Pareto front marked
//   DIR/plots/error-vs-triangles.{svg,png}  image error against triangle count, likewise
//   DIR/plots/screen-error-vs-level.{svg,png}  geo_max_px against the level, the <= 1 px band
//   DIR/plots/edge-length-vs-level.{svg,png}   mean_edge_px against the level, the 3-6 px band
//   DIR/index.html                          the plots, chosen levels side by side with their
//                                           difference pictures and wireframes, one
//                                           sentence per scene naming the level at which the
//                                           image error stops improving, and per series the
//                                           recommended levels and the rule behind each
//
// The HTML refers only to files under DIR by relative paths (no network, works opened from
// disk). Columns are found by their header names; unknown columns are ignored. Throws
// tessref::Error naming the file (and line) when sweep.csv is missing or malformed; then
// nothing is written. Each file is written under a temporary name and renamed into place,
// index.html last, so a failure never leaves a half-written page.
//
// The rules the page states (the Pareto front, the level at which the image error stops
// improving -- the knee --, the best level under a triangle budget, a dominated control stage,
// the gpu/exact ratio) and the strict reading of sweep.csv are in report_data.h; the plots'
// drawing (SVG and PNG from one list of shapes) in plot.h.
#pragma once

#include <string>

namespace tessref::sweep {

void write_sweep_report(const std::string& dir);

}  // namespace tessref::sweep
