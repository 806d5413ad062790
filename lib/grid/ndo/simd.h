/* ndo/simd.h — what the library's hot loops are compiled with: two
 * variants of a function, and four doubles as one value (internal to the
 * library, not installed).
 *
 * NDO_HOT_O3: compiled twice, for x86-64 (SSE2) and x86-64-v3 (AVX2), at
 * -O3, and the loader picks what the CPU runs (GCC function
 * multi-versioning).  With C11's default of no fused operations, every
 * double operation rounds the same on both, so the variants give the same
 * bits.  Sanitizer builds compile one variant: the sanitizers check the
 * source, not the instruction set.
 *
 * ndo__v4: four doubles, loaded and stored at any 8-byte boundary and
 * aliasing plain doubles (ndo__v4u, V4_LD, V4_ST): loops written four
 * entries at a time.  Each lane's operations are the scalar code's,
 * correctly rounded, so the same bits; V1_LD and V1_ST are the same loop
 * bodies' scalar tails. */
#ifndef NDO_SIMD_H
#define NDO_SIMD_H

/* (Not under ASan or TSan: TSan's runtime is not yet set up when the
 * loader calls the clones' resolvers, and the program dies before main.) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define NDO_HOT_O3 __attribute__((target_clones("arch=x86-64-v3", "default"), optimize("O3")))
#else
#define NDO_HOT_O3
#endif

typedef double ndo__v4 __attribute__((vector_size(32)));
typedef double ndo__v4u __attribute__((vector_size(32), aligned(8), may_alias));
typedef long long ndo__v4i __attribute__((vector_size(32)));
#define V4_LD(ptr) ((ndo__v4)(*(const ndo__v4u *)(ptr)))
#define V4_ST(ptr, x) (*(ndo__v4u *)(ptr) = (x))
#define V1_LD(ptr) (*(ptr))
#define V1_ST(ptr, x) (*(ptr) = (x))

#endif
