//! The one boundary every `extern "C"` body runs inside: panics become `SLOD_RESULT_PANIC`,
//! errors become a result code plus the thread-local message, and pointers are checked here.

use std::panic::{AssertUnwindSafe, catch_unwind};

use super::result::{FfiError, SlodResult, set_last_error};

/// Runs `f`, converting its error or panic into a result code and recording the message.
///
/// Unwind safety: a panic inside slod may leave the object it was working on half-updated. The
/// world's bookkeeping (arenas) is only touched after an operation succeeded, so the world itself
/// stays valid; the result code tells the host to destroy the object involved.
pub(crate) fn boundary(f: impl FnOnce() -> Result<(), FfiError>) -> SlodResult {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => {
            set_last_error(String::new());
            SlodResult::Ok
        }
        Ok(Err(e)) => {
            let code = e.code();
            set_last_error(e.to_string());
            code
        }
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            set_last_error(FfiError::Panic(msg).to_string());
            SlodResult::Panic
        }
    }
}

/// Borrows a caller pointer as a reference, or reports which argument was NULL.
///
/// # Safety
/// A non-NULL `p` must point to a valid, initialised `T` for the duration of the call.
pub(crate) unsafe fn arg<'a, T>(p: *const T, name: &'static str) -> Result<&'a T, FfiError> {
    // SAFETY: forwarded from the caller's contract; NULL is checked by `as_ref`.
    unsafe { p.as_ref() }.ok_or(FfiError::Null(name))
}

/// Borrows a caller pointer mutably, or reports which argument was NULL.
///
/// # Safety
/// A non-NULL `p` must point to a valid `T`, not aliased, for the duration of the call.
pub(crate) unsafe fn arg_mut<'a, T>(p: *mut T, name: &'static str) -> Result<&'a mut T, FfiError> {
    // SAFETY: forwarded from the caller's contract; NULL is checked by `as_mut`.
    unsafe { p.as_mut() }.ok_or(FfiError::Null(name))
}

/// Borrows a caller array of `len` elements (NULL allowed when `len` is 0).
///
/// # Safety
/// A non-NULL `p` must be valid for `len` reads of `T`.
pub(crate) unsafe fn slice<'a, T>(
    p: *const T,
    len: usize,
    name: &'static str,
) -> Result<&'a [T], FfiError> {
    if len == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(FfiError::Null(name));
    }
    if len > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(FfiError::invalid(name, "length too large"));
    }
    // SAFETY: non-NULL, length checked against isize::MAX bytes, validity per caller contract.
    Ok(unsafe { std::slice::from_raw_parts(p, len) })
}

/// Copies `data` out to a caller buffer under the one copy-out rule of the header:
/// * `out` NULL with `cap` 0 sizes the buffer: `*out_len` receives the element count, and the
///   call succeeds;
/// * otherwise `*out_len` and `out` are written only on success: with `cap` too small the call
///   returns `BUFFER_TOO_SMALL` (the message names the count needed), with `out` NULL and a
///   non-zero `cap` `NULL_ARGUMENT`, and nothing is written in either case.
///
/// # Safety
/// `out` must be valid for `cap` writes of `T` (or NULL with `cap` 0); `out_len` NULL or valid.
pub(crate) unsafe fn copy_out<T: Copy>(
    data: &[T],
    out: *mut T,
    cap: usize,
    out_len: *mut usize,
    name: &'static str,
) -> Result<(), FfiError> {
    // SAFETY: forwarded from the caller's contract, which is the same.
    unsafe { copy_out_map(data, |&x| x, out, cap, out_len, name) }
}

/// [`copy_out`] of `src` converted element by element with `f` (no intermediate buffer).
///
/// # Safety
/// As for [`copy_out`].
pub(crate) unsafe fn copy_out_map<S, T>(
    src: &[S],
    f: impl Fn(&S) -> T,
    out: *mut T,
    cap: usize,
    out_len: *mut usize,
    name: &'static str,
) -> Result<(), FfiError> {
    // SAFETY: forwarded from the caller's contract (`out_len` NULL or valid).
    unsafe { check_copy_out(src.len(), out, cap, out_len, name) }?;
    if out.is_null() {
        // Sizing: `check_copy_out` wrote the count.
        return Ok(());
    }
    for (i, s) in src.iter().enumerate() {
        // SAFETY: `out` is non-NULL and valid for `cap >= src.len()` writes per the caller
        // contract, and `i < src.len()`.
        unsafe { out.add(i).write(f(s)) };
    }
    // SAFETY: `out_len` checked non-NULL by `check_copy_out`; validity per caller contract.
    unsafe { *out_len = src.len() };
    Ok(())
}

/// The copy-out rule's checks, for a function that must check before producing `needed`
/// elements (expensive work is done only for a call that will succeed). Returns `Ok` for a
/// sizing call (`out` NULL, `cap` 0; `*out_len = needed` written) and for a call whose buffer
/// fits (nothing written yet); an error otherwise, with nothing written.
///
/// # Safety
/// `out_len` NULL or valid for a write.
pub(crate) unsafe fn check_copy_out<T>(
    needed: usize,
    out: *mut T,
    cap: usize,
    out_len: *mut usize,
    name: &'static str,
) -> Result<(), FfiError> {
    if out_len.is_null() {
        return Err(FfiError::Null("out_len"));
    }
    if out.is_null() {
        if cap != 0 {
            return Err(FfiError::Null(name));
        }
        // SAFETY: checked non-NULL above; validity per caller contract.
        unsafe { *out_len = needed };
        return Ok(());
    }
    if needed > cap {
        return Err(FfiError::BufferTooSmall {
            arg: name,
            cap,
            needed,
        });
    }
    Ok(())
}

/// Reads a NUL-terminated UTF-8 string argument.
///
/// # Safety
/// A non-NULL `p` must point to a NUL-terminated string valid for the duration of the call.
pub(crate) unsafe fn c_str<'a>(
    p: *const std::ffi::c_char,
    name: &'static str,
) -> Result<&'a str, FfiError> {
    if p.is_null() {
        return Err(FfiError::Null(name));
    }
    // SAFETY: non-NULL and NUL-terminated per the caller contract.
    let s = unsafe { std::ffi::CStr::from_ptr(p) };
    s.to_str()
        .map_err(|_| FfiError::invalid(name, "not valid UTF-8"))
}

/// Writes a value to a trailing output pointer.
///
/// # Safety
/// A non-NULL `out` must be valid for a write of `T`.
pub(crate) unsafe fn write_out<T>(
    out: *mut T,
    value: T,
    name: &'static str,
) -> Result<(), FfiError> {
    if out.is_null() {
        return Err(FfiError::Null(name));
    }
    // SAFETY: non-NULL, validity per caller contract.
    unsafe { out.write(value) };
    Ok(())
}
