#pragma once
// SIGTERM and SIGINT (what a batch scheduler sends at its time limit, what Ctrl-C sends through
// mpirun) are turned into a request to stop at the next step boundary: the handler only records
// the signal; Simulation::run agrees on it over all ranks and ends the run as "interrupted", so
// frames are complete and summary.json says where the run stopped.
namespace cassini {

void install_interrupt_handlers();  // SIGTERM, SIGINT; restarts interrupted system calls
int interrupt_signal();             // the signal received on this rank, 0 if none
const char* signal_name(int sig);   // "SIGTERM", "SIGINT", ...

}  // namespace cassini
