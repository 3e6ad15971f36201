//! Result codes, the thread-local error detail, and the errors the C layer reports.

use std::cell::RefCell;
use std::ffi::c_char;

/// Outcome of every fallible slod function. `SLOD_RESULT_OK` is 0; codes are only ever appended.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodResult {
    /// Success: the trailing output pointers were written.
    Ok = 0,
    /// A required pointer argument was NULL; `slod_last_error` names it.
    NullArgument = 1,
    /// An argument is out of range, NaN, inconsistent, or a desc did not come from its
    /// `slod_default_*_desc` function; `slod_last_error` names it.
    InvalidArgument = 2,
    /// An id is stale (its object was destroyed), from another world, or of the wrong kind.
    StaleId = 3,
    /// A caller buffer is too small; `*out_len` holds the number of elements needed.
    BufferTooSmall = 4,
    /// A file or memory blob could not be parsed (malformed or unsupported glTF).
    ParseError = 5,
    /// The operation is not possible in the object's current state (e.g. refining a node that is
    /// not on the cut, or one locked by a transition in flight). Nothing changed.
    Refused = 6,
    /// A file could not be read.
    IoError = 7,
    /// slod panicked internally; the object involved may be unusable and should be destroyed.
    Panic = 8,
}

/// Every error the C layer turns into a [`SlodResult`] plus a message.
#[derive(Debug, thiserror::Error)]
pub(crate) enum FfiError {
    #[error("argument `{0}` is NULL")]
    Null(&'static str),
    #[error("argument `{arg}`: {reason}")]
    Invalid { arg: &'static str, reason: String },
    #[error("argument `{0}`: stale, foreign or wrong-kind id")]
    StaleId(&'static str),
    #[error("buffer `{arg}` holds {cap} elements but {needed} are needed")]
    BufferTooSmall {
        arg: &'static str,
        cap: usize,
        needed: usize,
    },
    #[error("parse error: {0}")]
    Parse(String),
    #[error("refused: {0}")]
    Refused(String),
    #[error("cannot read `{path}`: {reason}")]
    Io { path: String, reason: String },
    #[error("internal panic: {0}")]
    Panic(String),
}

impl FfiError {
    // Callers hand over temporaries (messages, errors); taking them by value reads best.
    #[allow(clippy::needless_pass_by_value)]
    pub(crate) fn invalid(arg: &'static str, reason: impl ToString) -> Self {
        FfiError::Invalid {
            arg,
            reason: reason.to_string(),
        }
    }

    pub(crate) fn code(&self) -> SlodResult {
        match self {
            FfiError::Null(_) => SlodResult::NullArgument,
            FfiError::Invalid { .. } => SlodResult::InvalidArgument,
            FfiError::StaleId(_) => SlodResult::StaleId,
            FfiError::BufferTooSmall { .. } => SlodResult::BufferTooSmall,
            FfiError::Parse(_) => SlodResult::ParseError,
            FfiError::Refused(_) => SlodResult::Refused,
            FfiError::Io { .. } => SlodResult::IoError,
            FfiError::Panic(_) => SlodResult::Panic,
        }
    }
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

pub(crate) fn set_last_error(message: String) {
    LAST_ERROR.with(|e| *e.borrow_mut() = message);
}

/// A static, NUL-terminated description of a result code (never NULL; unknown codes get
/// "unknown result code").
#[unsafe(no_mangle)]
pub extern "C" fn slod_result_str(code: u32) -> *const c_char {
    let s: &'static [u8] = match code {
        0 => b"ok\0",
        1 => b"null argument\0",
        2 => b"invalid argument\0",
        3 => b"stale, foreign or wrong-kind id\0",
        4 => b"buffer too small\0",
        5 => b"parse error\0",
        6 => b"operation refused in the current state\0",
        7 => b"i/o error\0",
        8 => b"internal panic\0",
        _ => b"unknown result code\0",
    };
    s.as_ptr().cast()
}

/// Copies the calling thread's last error message (empty after a success) into `buf` as a
/// NUL-terminated string, truncated to `cap - 1` bytes, and writes the full message length
/// (without NUL) to `*out_len` if `out_len` is not NULL. `buf` may be NULL when `cap` is 0.
/// Thread-local: each thread sees the detail of its own last call.
///
/// # Safety
/// `buf` must be valid for `cap` bytes of writes (or NULL with `cap` 0); `out_len` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_last_error(buf: *mut c_char, cap: usize, out_len: *mut usize) {
    LAST_ERROR.with(|e| {
        let msg = e.borrow();
        if !buf.is_null() && cap > 0 {
            let n = msg.len().min(cap - 1);
            // SAFETY: the caller guarantees `buf` is valid for `cap` bytes; we write n + 1 <= cap.
            unsafe {
                std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n);
                *buf.add(n) = 0;
            }
        }
        if !out_len.is_null() {
            // SAFETY: the caller guarantees a non-NULL `out_len` is valid for a write.
            unsafe { *out_len = msg.len() };
        }
    });
}
