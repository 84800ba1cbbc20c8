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

/* The largest even count not above count: a loop over it runs a whole number of 2-wide vectors (GCC at -O2
 * vectorises a loop only when its trip count is a multiple of the vector length), then one element more. */
#define EVEN(count) ((count) & ~1)

/* Keeps a function out of line where inlining it costs GCC (-O2) the vectorisation of the loops around it
 * (it forgets the RESTRICT of an inlined kernel). Other compilers ignore it. */
#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif

/* The hot loops compiled three times, for AVX-512 (x86-64-v4), AVX2 (v3) and the baseline; the loader picks
 * the one the CPU runs (an ifunc: GCC 11+ on x86-64 Linux). The clones compute the same bits as each other
 * and as any other build of the sources: they never contract a multiply and an add into an FMA (GCC's GNU
 * modes would, fmpy compile builds in one) and never reassociate. Elsewhere, or with -DLATTICE_NO_CLONES,
 * one build. */
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 11 && defined(__x86_64__) && defined(__linux__) && \
    !defined(LATTICE_NO_CLONES)
#define VECTOR_CLONES \
    __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"), optimize("fp-contract=off")))
#else
#define VECTOR_CLONES
#endif

#endif
