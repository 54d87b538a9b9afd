//! Tuned settings saved to and loaded from JSON: every fixed volume's [`DdgiVolume`] (in entity
//! order) and the first camera's [`DdgiCascades`], if any. Fields left out of a file keep their
//! defaults; a field the settings do not have, a value of the wrong type or out of its range is
//! refused with the file, the field and the value.
//!
//! ```json
//! { "volumes": [ { "rays_per_probe": 64, "hysteresis": 0.95, "adaptive": { "min_rays": 8 } } ],
//!   "cascades": null }
//! ```

use std::path::Path;

use bevy_ecs::prelude::*;
use ddgi::cascades::{DdgiCascade, DdgiFirstCameraCascades};
use ddgi::{DdgiAdaptive, DdgiCascades, DdgiVolume, DdgiWeights};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// What a settings file holds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DdgiSettingsFile {
    /// The fixed volumes' settings (not the cascades' own volumes), in entity order.
    pub volumes: Vec<DdgiVolume>,
    /// The first camera's cascades (the resource [`DdgiFirstCameraCascades`]), if the app has them.
    pub cascades: Option<DdgiCascades>,
}

/// Why settings could not be saved or loaded. Each names the file; a bad value also names its
/// field (as a path: `volumes[0].adaptive.min_rays`) and the value.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SettingsError {
    /// The file could not be read or written.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// What the system said.
        message: String,
    },
    /// The file is not JSON (with the line and column).
    #[error("{file}: not valid JSON: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// serde_json's message, with the line and column.
        message: String,
    },
    /// A field has a value of the wrong type, or is not a field of the settings.
    #[error("{file}: {field} = {value}: {message}")]
    Field {
        /// The file.
        file: String,
        /// The field's path, e.g. `volumes[0].adaptive.min_rays`.
        field: String,
        /// The value found, as JSON.
        value: String,
        /// What is wrong, e.g. `invalid type: string "many", expected u32`.
        message: String,
    },
    /// A value is of the right type but out of its range (the settings' own check).
    #[error("{file}: {at}: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// The volume, e.g. `volumes[1]` or `cascades`.
        at: String,
        /// The check's message, naming the field and the value.
        message: String,
    },
    /// The file holds more volumes than the app has.
    #[error("{file}: {found} volumes, the app has {have}")]
    VolumeCount {
        /// The file.
        file: String,
        /// Volumes in the file.
        found: usize,
        /// Fixed volumes in the app.
        have: usize,
    },
}

/// The settings of `world` as a file would hold them: the fixed volumes in entity order, and the
/// first camera's cascades.
pub fn collect(world: &mut World) -> DdgiSettingsFile {
    let mut query = world.query_filtered::<(Entity, &DdgiVolume), Without<DdgiCascade>>();
    let mut volumes: Vec<(Entity, DdgiVolume)> = query.iter(world).map(|(e, v)| (e, v.clone())).collect();
    volumes.sort_by_key(|(e, _)| *e);
    DdgiSettingsFile {
        volumes: volumes.into_iter().map(|(_, v)| v).collect(),
        cascades: world.get_resource::<DdgiFirstCameraCascades>().map(|c| c.0.clone()),
    }
}

/// Writes `settings` to `path` as pretty JSON.
pub fn save(settings: &DdgiSettingsFile, path: &Path) -> Result<(), SettingsError> {
    let file = path.display().to_string();
    let text = serde_json::to_string_pretty(settings).map_err(|e| SettingsError::Io { file: file.clone(), message: e.to_string() })?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| SettingsError::Io { file: file.clone(), message: e.to_string() })?;
    }
    std::fs::write(path, text).map_err(|e| SettingsError::Io { file, message: e.to_string() })
}

/// Reads and checks the settings in `path` (see [`parse`]).
pub fn load(path: &Path) -> Result<DdgiSettingsFile, SettingsError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SettingsError::Io { file: file.clone(), message: e.to_string() })?;
    parse(&text, &file)
}

/// Parses settings from JSON `text` (from `file`, for the messages) and checks every value: a
/// syntax error with its line and column; a value of the wrong type or an unknown field with its
/// path and value; a value out of range with the settings' own check.
pub fn parse(text: &str, file: &str) -> Result<DdgiSettingsFile, SettingsError> {
    let value: Value = serde_json::from_str(text).map_err(|e| SettingsError::Syntax { file: file.into(), message: e.to_string() })?;
    let settings = serde_json::from_value::<DdgiSettingsFile>(value.clone()).map_err(|e| {
        let (field, bad) = locate::<DdgiSettingsFile>(&value, "").unwrap_or_else(|| ("(the file)".into(), value.clone()));
        SettingsError::Field { file: file.into(), field, value: bad.to_string(), message: strip_position(&e.to_string()) }
    })?;
    for (i, v) in settings.volumes.iter().enumerate() {
        v.validate().map_err(|e| SettingsError::Invalid { file: file.into(), at: format!("volumes[{i}]"), message: e.to_string() })?;
    }
    if let Some(c) = &settings.cascades {
        c.validate().map_err(|e| SettingsError::Invalid { file: file.into(), at: "cascades".into(), message: e.to_string() })?;
    }
    Ok(settings)
}

/// serde_json's message without its " at line L column C" (meaningless for a value re-read).
fn strip_position(message: &str) -> String {
    message.find(" at line ").map_or(message, |i| &message[..i]).to_string()
}

/// The path and value of the first field of `value` that `T` refuses: each field is tried alone
/// (the others default), and the culprit's own fields in turn when it is a settings struct.
fn locate<T: serde::de::DeserializeOwned>(value: &Value, path: &str) -> Option<(String, Value)> {
    let Value::Object(map) = value else { return Some((display_path(path), value.clone())) };
    for (key, v) in map {
        let alone = Value::Object([(key.clone(), v.clone())].into_iter().collect());
        if serde_json::from_value::<T>(alone).is_ok() {
            continue;
        }
        let here = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
        return Some(
            match (std::any::type_name::<T>(), key.as_str()) {
                (t, "volumes") if t.ends_with("DdgiSettingsFile") => locate_list::<DdgiVolume>(v, &here),
                (t, "cascades") if t.ends_with("DdgiSettingsFile") && v.is_object() => locate::<DdgiCascades>(v, &here),
                (t, "volume") if t.ends_with("DdgiCascades") && v.is_object() => locate::<DdgiVolume>(v, &here),
                (t, "adaptive") if t.ends_with("DdgiVolume") && v.is_object() => locate::<DdgiAdaptive>(v, &here),
                (t, "weights") if t.ends_with("DdgiVolume") && v.is_object() => locate::<DdgiWeights>(v, &here),
                _ => None,
            }
            .unwrap_or((here, v.clone())),
        );
    }
    None
}

/// [`locate`] over a list of `T` at `path`.
fn locate_list<T: serde::de::DeserializeOwned>(value: &Value, path: &str) -> Option<(String, Value)> {
    let Value::Array(items) = value else { return Some((path.into(), value.clone())) };
    items
        .iter()
        .enumerate()
        .find(|(_, item)| serde_json::from_value::<T>((*item).clone()).is_err())
        .map(|(i, item)| locate::<T>(item, &format!("{path}[{i}]")).unwrap_or((format!("{path}[{i}]"), item.clone())))
}

fn display_path(path: &str) -> String {
    if path.is_empty() { "(the file)".into() } else { path.into() }
}

/// Applies `settings` to `world`: the i-th fixed volume (entity order) takes the i-th volume's
/// settings; the first camera's cascades take the cascades'. Refuses a file with more volumes than
/// the app has.
pub fn apply(world: &mut World, settings: &DdgiSettingsFile, file: &str) -> Result<(), SettingsError> {
    let mut query = world.query_filtered::<(Entity, &DdgiVolume), Without<DdgiCascade>>();
    let mut entities: Vec<Entity> = query.iter(world).map(|(e, _)| e).collect();
    entities.sort();
    if settings.volumes.len() > entities.len() {
        return Err(SettingsError::VolumeCount { file: file.into(), found: settings.volumes.len(), have: entities.len() });
    }
    for (entity, volume) in entities.iter().zip(&settings.volumes) {
        if let Some(mut v) = world.get_mut::<DdgiVolume>(*entity)
            && *v != *volume
        {
            *v = volume.clone();
        }
    }
    if let Some(cascades) = &settings.cascades
        && let Some(mut shared) = world.get_resource_mut::<DdgiFirstCameraCascades>()
    {
        shared.0 = cascades.clone();
    }
    Ok(())
}
