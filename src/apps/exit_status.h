// The exit statuses of the `penumbra` executable, one list for every command
// (`penumbra --help` prints kExitStatusHelp; scripts/study.py uses the same).
#pragma once

namespace pn {

enum ExitStatus : int {
  kExitOk = 0,
  kExitError = 1,        // bad input, an output that cannot be written, too little memory: one line on stderr
  kExitUsage = 2,        // the command line itself is wrong (unknown command or option, missing argument, a value
                         // out of range or unknown, options that do not go together)
  kExitDiffer = 3,       // `compare`: the two images differ (the statistical test or the bound on the means failed)
  kExitNonFinite = 4,    // the outputs were written, but some samples were NaN or infinite and left out
  kExitInterrupted = 130,  // Ctrl-C (SIGINT) or SIGTERM: stopped; files already written are complete
};

inline const char* const kExitStatusHelp =
    "Exit status: 0 success; 1 error (one line on stderr naming the file and field; an existing output file is\n"
    "never left half-written); 2 bad command line (an unknown command or option, a value out of range); 3 compare:\n"
    "the images differ (either test); 4 the outputs were written but some samples were NaN or infinite and were\n"
    "left out (a warning says how many and where); 130 interrupted (Ctrl-C).";

}  // namespace pn
