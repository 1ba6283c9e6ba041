// Entry points of the workbench subcommands: each parses its flags and calls
// the library. They return the process exit code; errors a user can cause
// throw and are printed as one line by main().
#pragma once

namespace furn {

int RunCatalog(int argc, char** argv);
int RunRender(int argc, char** argv);
int RunGenerate(int argc, char** argv);
int RunDataset(int argc, char** argv);
int RunTrain(int argc, char** argv);
int RunModel(int argc, char** argv);
int RunEvalParts(int argc, char** argv);
int RunDetect(int argc, char** argv);
int RunEvaluate(int argc, char** argv);
int RunCrossval(int argc, char** argv);
int RunRegress(int argc, char** argv);
int RunReport(int argc, char** argv);
int RunHistory(int argc, char** argv);
int RunTune(int argc, char** argv);
int RunAdapt(int argc, char** argv);
int RunJobs(int argc, char** argv);

}  // namespace furn
