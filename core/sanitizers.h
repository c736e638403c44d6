// MESHMUX_SANITIZED: 1 when built with AddressSanitizer, ThreadSanitizer or MemorySanitizer
// (GCC defines __SANITIZE_*__, clang answers __has_feature). Their shadow memory is terabytes
// of reserved address space, so address-space and data limits (setrlimit) must stay off.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define MESHMUX_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define MESHMUX_SANITIZED 1
#endif
#endif
#ifndef MESHMUX_SANITIZED
#define MESHMUX_SANITIZED 0
#endif
