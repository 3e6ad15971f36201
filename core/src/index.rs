//! [`index_type!`](crate::index_type): one pattern for every index newtype of the workspace.

/// Defines an index newtype: `$name(u32)` with a private field, ordered and hashable, with
/// `new(usize)`/`index()` for indexing per-item arrays and `from_raw(u32)`/`raw()` for storage
/// and foreign-language boundaries. `Debug` and `Display` print the short prefix and the index
/// (`index_type!(pub struct NodeId, "n")` prints `n7`).
///
/// ```
/// slod_core::index_type! {
///     /// A widget, by its index in the widget table.
///     pub struct WidgetId, "widget "
/// }
/// let w = WidgetId::new(3);
/// assert_eq!(w.index(), 3);
/// assert_eq!(WidgetId::from_raw(3), w);
/// assert_eq!(format!("{w}"), "widget 3");
/// ```
#[macro_export]
macro_rules! index_type {
    ($(#[$doc:meta])* $vis:vis struct $name:ident, $short:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
        $vis struct $name(u32);

        impl $name {
            /// The id of the item stored at `index` (which must fit a `u32`).
            #[inline]
            $vis fn new(index: usize) -> Self {
                debug_assert!(index <= u32::MAX as usize, "index {index} does not fit a u32");
                $name(index as u32)
            }

            /// The id whose raw value is `raw` (for storage and foreign-language boundaries).
            #[inline]
            $vis const fn from_raw(raw: u32) -> Self {
                $name(raw)
            }

            /// The item's index, for indexing per-item arrays.
            #[inline]
            $vis const fn index(self) -> usize {
                self.0 as usize
            }

            /// The raw `u32` value.
            #[inline]
            $vis const fn raw(self) -> u32 {
                self.0
            }
        }

        impl ::core::fmt::Debug for $name {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                write!(f, concat!($short, "{}"), self.0)
            }
        }

        impl ::core::fmt::Display for $name {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                write!(f, concat!($short, "{}"), self.0)
            }
        }
    };
}

#[cfg(test)]
mod tests {
    crate::index_type! {
        /// A test id.
        pub(crate) struct TestId, "t"
    }

    #[test]
    fn round_trips_and_orders() {
        let a = TestId::new(4);
        assert_eq!((a.index(), a.raw()), (4, 4));
        assert_eq!(TestId::from_raw(4), a);
        assert!(TestId::new(3) < a);
        assert_eq!(format!("{a:?} {a}"), "t4 t4");
        assert_eq!(TestId::default().index(), 0);
    }
}
