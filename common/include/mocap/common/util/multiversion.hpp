#pragma once
// Function multiversioning for the hot loops of the energy model and the
// search: GCC on x86-64 builds clones next to the baseline one and picks at
// load time (ifunc), so one binary runs everywhere and uses the wider
// vectors where the CPU has them:
//   MOCAP_MULTIVERSION_V3  an x86-64-v3 (AVX2) clone
//   MOCAP_MULTIVERSION_V4  an x86-64-v4 (AVX-512) and an x86-64-v3 clone
// Such a function is never inlined into its callers, so it may be called
// from any file. Off with MOCAP_NO_TARGET_CLONES, under the sanitizers
// (ifunc resolvers run before the sanitizer runtime is up) and on other
// compilers. The build forbids contraction into FMA (-ffp-contract=off), so
// every clone computes the same values.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(MOCAP_NO_TARGET_CLONES) && !defined(__SANITIZE_ADDRESS__)
#define MOCAP_MULTIVERSION_V3 __attribute__((target_clones("arch=x86-64-v3", "default")))
#define MOCAP_MULTIVERSION_V4 \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MOCAP_MULTIVERSION_V3
#define MOCAP_MULTIVERSION_V4
#endif
