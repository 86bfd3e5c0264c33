// The MPI processes of `mpirun -n K frichb study SCENE` as a StudyCommunicator. Built only
// when CMake finds MPI (FRICHB_HAVE_MPI); MPI is initialised only when the program was
// started by an MPI launcher, so a plain `frichb study` never touches MPI.
#pragma once

#include <memory>

#include "frichb/core/commands/study.hpp"

namespace frichb::app {

// True when the environment says an MPI launcher started this process with more than one
// rank (OpenMPI's OMPI_COMM_WORLD_SIZE, PMI_SIZE, or PMIX's rank with a size).
bool launched_by_mpi();

// Initialises MPI (finalised when the object dies). Null when built without MPI.
std::unique_ptr<core::StudyCommunicator> make_mpi_communicator();

}  // namespace frichb::app
