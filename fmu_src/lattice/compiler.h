/* Optimisation hints shared by the hot loops of lattice.c and solver.c; they never change a result. */
#ifndef LATTICE_COMPILER_H
#define LATTICE_COMPILER_H

/* restrict where the compiler knows it (C99; MSVC spells it __restrict). */
#if defined(__STDC_VERSION__) && __STDC_VERSION__ >= 199901L
#define RESTRICT restrict
#elif defined(_MSC_VER)
#define RESTRICT __restrict
#else
#define RESTRICT
#endif

/* Keeps a function out of line where inlining it costs GCC (-O2) the vectorisation of the loops around it
 * (it forgets the RESTRICT of an inlined kernel). Other compilers ignore it. */
#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif

#endif
