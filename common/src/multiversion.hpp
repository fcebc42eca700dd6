#pragma once
// Function multiversioning for the hot loops of the energy model: GCC on
// x86-64 builds an x86-64-v3 (AVX2 + FMA) clone next to the baseline one and
// picks at load time (ifunc), so one binary runs everywhere and uses FMA where
// the CPU has it. Define MOCAP_NO_TARGET_CLONES to turn it off (sanitizer
// builds do: ifunc resolvers run before the sanitizer runtime is up).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(MOCAP_NO_TARGET_CLONES) && !defined(__SANITIZE_ADDRESS__)
#define MOCAP_MULTIVERSION_V3 __attribute__((target_clones("arch=x86-64-v3", "default")))
#define MOCAP_MULTIVERSION_V4 \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MOCAP_MULTIVERSION_V3
#define MOCAP_MULTIVERSION_V4
#endif
