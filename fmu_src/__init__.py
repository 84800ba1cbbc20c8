"""The FMU's C sources shared by every FMI version's glue: the model (lattice/) and the instance (common/)."""

MODEL_SOURCES = ["common/instance.c", "lattice/lattice.c", "lattice/solver.c", "lattice/model.c",
                 "lattice/cosimulation.c"]
MODEL_HEADERS = ["common/instance.h", "lattice/lattice.h", "lattice/solver.h", "lattice/model.h",
                 "lattice/contract.h", "lattice/cosimulation.h",
                 "lattice/compiler.h", "lattice/dop853_coefficients.h"]
