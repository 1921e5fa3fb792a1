//! The scissor hold (see the crate docs for why it interposes MuJoCo's GL loader).

use std::cell::Cell;
use std::ffi::{CStr, c_char, c_void};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

/// `GL_SCISSOR_TEST` (OpenGL 1.0).
const GL_SCISSOR_TEST: u32 = 0x0C11;

type GetProcAddress = unsafe extern "C" fn(*const c_char) -> *mut c_void;
type GlCap = unsafe extern "C" fn(u32);
type GlScissor = unsafe extern "C" fn(i32, i32, i32, i32);

/// A rectangle in GL window coordinates: origin at the bottom-left pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GlRect {
    pub left: i32,
    pub bottom: i32,
    pub width: i32,
    pub height: i32,
}

/// The real EGL loader and the three GL entry points the hold needs.
struct RealGl {
    get_proc: GetProcAddress,
    disable: GlCap,
    scissor: GlScissor,
    // Keeps libEGL mapped while the pointers above are in use.
    _egl: libloading::Library,
}

static REAL: OnceLock<Option<RealGl>> = OnceLock::new();
/// Set once MuJoCo's loader has fetched `glDisable` through [`eglGetProcAddress`].
static INTERPOSED: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// The rectangle held on this thread (GL contexts are current per thread).
    static HELD: Cell<Option<GlRect>> = const { Cell::new(None) };
}

fn real() -> Option<&'static RealGl> {
    REAL.get_or_init(|| load().ok()).as_ref()
}

fn load() -> Result<RealGl, libloading::Error> {
    // SAFETY: libEGL's initialisers are the same ones glutin runs when it opens the library.
    let egl = unsafe { libloading::Library::new("libEGL.so.1")? };
    // SAFETY: `eglGetProcAddress` has this signature in every EGL version.
    let get_proc: GetProcAddress = unsafe { *egl.get::<GetProcAddress>(b"eglGetProcAddress\0")? };
    // SAFETY: EGL 1.5 (and EGL_KHR_get_all_proc_addresses) returns core GL entry points by
    // name; a non-null answer has the GL signature named.
    let (disable, scissor) = unsafe {
        let disable = get_proc(c"glDisable".as_ptr());
        let scissor = get_proc(c"glScissor".as_ptr());
        if disable.is_null() || scissor.is_null() {
            return Err(libloading::Error::DlSymUnknown);
        }
        (
            std::mem::transmute::<*mut c_void, GlCap>(disable),
            std::mem::transmute::<*mut c_void, GlScissor>(scissor),
        )
    };
    Ok(RealGl {
        get_proc,
        disable,
        scissor,
        _egl: egl,
    })
}

/// The process's `eglGetProcAddress`, found by MuJoCo's GL loader before libEGL's own.
///
/// # Safety
/// `name` is null or a NUL-terminated string, as EGL requires of its callers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn eglGetProcAddress(name: *const c_char) -> *mut c_void {
    let Some(gl) = real() else {
        return std::ptr::null_mut();
    };
    if !name.is_null() {
        // SAFETY: non-null and NUL-terminated by this function's contract.
        match unsafe { CStr::from_ptr(name) }.to_bytes() {
            b"glDisable" => {
                INTERPOSED.store(true, Ordering::Relaxed);
                return held_disable as *mut c_void;
            }
            b"glScissor" => return held_scissor as *mut c_void,
            _ => {}
        }
    }
    // SAFETY: forwards the caller's (valid) argument to the real loader.
    unsafe { (gl.get_proc)(name) }
}

/// `glDisable`, except that the scissor test stays on while a rectangle is held.
extern "C" fn held_disable(cap: u32) {
    if cap == GL_SCISSOR_TEST && HELD.get().is_some() {
        return;
    }
    if let Some(gl) = real() {
        // SAFETY: called by GL client code on a thread with a current context, as glDisable is.
        unsafe { (gl.disable)(cap) }
    }
}

/// `glScissor`, except that a held rectangle replaces the one asked for.
extern "C" fn held_scissor(left: i32, bottom: i32, width: i32, height: i32) {
    let r = HELD.get().unwrap_or(GlRect {
        left,
        bottom,
        width,
        height,
    });
    if let Some(gl) = real() {
        // SAFETY: called by GL client code on a thread with a current context.
        unsafe { (gl.scissor)(r.left, r.bottom, r.width, r.height) }
    }
}

/// True once MuJoCo's GL functions came through this crate, i.e. a hold limits rasterisation.
pub fn is_interposed() -> bool {
    INTERPOSED.load(Ordering::Relaxed)
}

/// Makes sure the interposer is linked into the binary (it is only referenced by name from C).
pub(crate) fn keep_linked() {
    std::hint::black_box(eglGetProcAddress as *const ());
}

/// Runs `draw` (a `mjr_render` with the full viewport) so that it clears and rasterises only
/// `rect`; every pixel inside comes out exactly as in an unscissored render, because the scissor
/// test discards fragments without changing how any fragment is computed. Must be called on the
/// thread where the drawing context is current; the scissor test is off again afterwards.
pub fn hold<R>(rect: GlRect, draw: impl FnOnce() -> R) -> R {
    struct Release;
    impl Drop for Release {
        fn drop(&mut self) {
            HELD.set(None);
            if is_interposed() {
                held_disable(GL_SCISSOR_TEST);
            }
        }
    }
    HELD.set(Some(rect));
    let _release = Release;
    draw()
}
