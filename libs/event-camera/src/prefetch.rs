//! A cache hint for loops over scattered pixels whose next few indices are known ahead.

/// Asks the CPU to bring the cache line of `slice[index]` towards L1 ahead of use: a hint that
/// changes no result. An index past the end (an unused term's empty array) asks for nothing: a
/// hint at an unmapped address still costs a page walk.
#[inline(always)]
pub(crate) fn prefetch<T>(slice: &[T], index: usize) {
    #[cfg(target_arch = "x86_64")]
    if index < slice.len() {
        let p = slice.as_ptr().wrapping_add(index);
        // SAFETY: a prefetch is only a hint: it never faults and reads nothing observable; the
        // address is inside the slice anyway; SSE is part of the x86_64 baseline.
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (slice, index);
}
