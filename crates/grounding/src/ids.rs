//! Typed `u32` ids into the task's dense tables.

macro_rules! id {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
        pub struct $name(pub u32);

        impl $name {
            /// The id as a 0-based index into its table.
            #[inline]
            pub fn index(self) -> usize {
                self.0 as usize
            }

            /// The id of a 0-based table index; `index` must fit in a `u32` (larger values are
            /// truncated, not checked).
            #[inline]
            pub fn from_index(index: usize) -> $name {
                $name(index as u32)
            }
        }
    };
}

id!(
    /// A fluent fact of a [`crate::Task`].
    FactId
);
id!(
    /// A grounded action of a [`crate::Task`].
    ActionId
);
id!(
    /// An object or constant.
    ObjectId
);
id!(
    /// A predicate of the domain.
    PredicateId
);
id!(
    /// An action schema of the domain.
    SchemaId
);
