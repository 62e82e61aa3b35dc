// Subcommands of the `loci` command line. Each module's commands live in their own file and
// register themselves on the CLI11 app; main.cc calls every Register*.
#pragma once

#include <CLI/CLI.hpp>

namespace loci::cli {

// Exit code of the command that ran (set by the command's callback).
int& ExitCode();

// The `loci bench` group: created on first use, shared by every benchmark command.
CLI::App* BenchGroup(CLI::App& app);
// The `loci eval` group: likewise shared by every evaluation command.
CLI::App* EvalGroup(CLI::App& app);

void RegisterEvalCommands(CLI::App& app);
// `loci synth` (synth/): synthetic RGB-D sequences with ground truth.
void RegisterSynthCommands(CLI::App& app);

// `loci detect` and `loci bench detect` (detection/); the bench group is reused.
void RegisterDetectCommand(CLI::App& app);
void RegisterBenchDetectCommand(CLI::App& app);
// `loci bench track` (client/tracking); adds or reuses the `bench` group.
void RegisterBenchTrackCommand(CLI::App& app);

// `loci bench query` (query/); adds or reuses the `bench` group.
void RegisterBenchQueryCommand(CLI::App& app);

// `loci export`, `loci eval objects`, `loci bench ingest` (server/); eval/bench groups reused.
void RegisterExportCommand(CLI::App& app);
void RegisterEvalObjectsCommand(CLI::App& app);
// `loci eval loops`: a server's stored loop matches and its odometry against ground truth.
void RegisterEvalLoopsCommand(CLI::App& app);
void RegisterBenchIngestCommand(CLI::App& app);
void RegisterBenchLoadCommand(CLI::App& app);
void RegisterBenchFleetCommand(CLI::App& app);
void RegisterBenchReplicaCommand(CLI::App& app);
// `loci bench merge`: time for a robot that starts anywhere to join the map (server/align/).
void RegisterBenchMergeCommand(CLI::App& app);
// `loci reprocess` and `loci bench restart` (server/: products, checkpoints, restart).
void RegisterReprocessCommand(CLI::App& app);
void RegisterBenchRestartCommand(CLI::App& app);
// `loci migrate`: a SQLite map into an empty PostgreSQL site, every id kept (server/postgres/).
void RegisterMigrateCommand(CLI::App& app);
// `loci bench graph` (server/graph/): pose-graph solve time and ATE on synthetic loops.
void RegisterBenchGraphCommand(CLI::App& app);

// `loci bench place` (server/place/): feature extraction, feature bytes, place-recognition query
// time against 1k and 10k keyframes.
void RegisterBenchPlaceCommand(CLI::App& app);

// `loci bench report` (cli/report/): evaluation report on a TUM folder.
void RegisterBenchReportCommand(CLI::App& app);

// `loci bench objects` (cli/report/synth_objects_eval.h): the object map on varied synthetic
// rooms with detector noise, over many seeds.
void RegisterBenchObjectsCommand(CLI::App& app);
void RegisterBenchChangesCommand(CLI::App& app);

// `loci ask`, `loci objects`, `loci stats` (gRPC clients of a running loci-server).
void RegisterAskCommand(CLI::App& app);
void RegisterObjectsCommands(CLI::App& app);

}  // namespace loci::cli
