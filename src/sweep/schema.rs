//! OpenAPI schema pieces written by hand, for the spec leaves whose `Deserialize` is
//! hand-written (numbers, counts, ranges, named choices), and [`hand_schema`] that
//! implements `utoipa::ToSchema` with one of them.

use utoipa::openapi::schema::{ArrayItems, Schema, SchemaType, Type};
use utoipa::openapi::{ArrayBuilder, ObjectBuilder, OneOfBuilder, RefOr};

/// `{"type": ty}` with a description.
pub fn typed(ty: Type, description: &str) -> Schema {
    ObjectBuilder::new()
        .schema_type(SchemaType::Type(ty))
        .description(Some(description))
        .into()
}

/// A string, one of `names`.
pub fn one_of_names(names: &[&str], description: &str) -> Schema {
    ObjectBuilder::new()
        .schema_type(SchemaType::Type(Type::String))
        .enum_values(Some(names.iter().copied()))
        .description(Some(description))
        .into()
}

/// `[first, last, count]`.
pub fn range3(description: &str) -> Schema {
    ArrayBuilder::new()
        .prefix_items([
            typed(Type::Number, "first value"),
            typed(Type::Number, "last value"),
            ObjectBuilder::new()
                .schema_type(SchemaType::Type(Type::Integer))
                .minimum(Some(1))
                .description(Some("number of values, at least 1"))
                .into(),
        ])
        .items(ArrayItems::False)
        .min_items(Some(3))
        .description(Some(description))
        .into()
}

/// A non-negative integer.
pub fn count(description: &str) -> Schema {
    ObjectBuilder::new()
        .schema_type(SchemaType::Type(Type::Integer))
        .minimum(Some(0))
        .description(Some(description))
        .into()
}

/// Any of `items`.
pub fn any_of(items: impl IntoIterator<Item = Schema>, description: &str) -> Schema {
    let mut b = OneOfBuilder::new().description(Some(description));
    for s in items {
        b = b.item(s);
    }
    b.into()
}

/// `schema` as the `RefOr` utoipa's traits return.
pub fn inline(schema: Schema) -> RefOr<Schema> {
    RefOr::T(schema)
}

/// Implements `utoipa::ToSchema` for a type whose schema is written by hand (`$schema`: a
/// `utoipa::openapi::schema::Schema` expression).
macro_rules! hand_schema {
    ($ty:ty, $name:literal, $schema:expr) => {
        impl utoipa::PartialSchema for $ty {
            fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
                $crate::sweep::schema::inline($schema)
            }
        }
        impl utoipa::ToSchema for $ty {
            fn name() -> std::borrow::Cow<'static, str> {
                std::borrow::Cow::Borrowed($name)
            }
        }
    };
}
pub(crate) use hand_schema;
