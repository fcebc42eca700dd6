#pragma once
// Internal to mocap_search: function multiversioning of the search's hot
// loops, as in common's (an AVX-512 and an AVX2 clone next to the baseline
// one, picked at load time through an ifunc; such a function is never
// inlined into its callers, so it may be called from any file). Off with
// MOCAP_NO_TARGET_CLONES, under the sanitizers and on other compilers.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(MOCAP_NO_TARGET_CLONES) && !defined(__SANITIZE_ADDRESS__)
#define MOCAP_SEARCH_MULTIVERSION \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MOCAP_SEARCH_MULTIVERSION
#endif
