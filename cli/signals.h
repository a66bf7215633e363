// SIGINT and SIGTERM for the long commands (render, convert, optimize, sample, export
// coco): the first one sets a cancellation flag that the library call polls, and the
// command stops at the next clean point, says what is done and how to resume, and exits
// 130 (SIGINT) or 143 (SIGTERM). The handler resets itself when it runs, so a second
// signal takes the default action and ends the process at once.
#pragma once

#include <string>

#include "solid/formats/cancel.h"

namespace solid::cli {

// Remembers the command line, for the resume hint.
void SetCommandLine(int argc, char** argv);
// The command line as typed, each argument shell-quoted.
std::string CommandLine();

// Installs the handlers (once); returns the flag they set.
const CancelFlag* InstallStopHandlers();
// The signal that asked to stop, 0 when none arrived.
int StopSignal();
// "SIGINT", "SIGTERM".
std::string StopSignalName();
// 128 + the signal: 130 for SIGINT, 143 for SIGTERM.
int StopExitCode();

}  // namespace solid::cli
