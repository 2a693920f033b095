//! VirtualHome's class-level script verbs, as in the paper's Phase II prompt
//! (`walk kitchen`, `grab wineglass`, `putin wineglass dishwasher`).
//!
//! A table maps each EAI PDDL schema to its VirtualHome script verb (the verbs of
//! VirtualHome's action space, lowercased without separators); the character parameter is
//! dropped and the remaining arguments are written by their class names, which is what EAI's
//! PDDL objects are. `walk` is one verb for two schemas: it is `walk_into` when the target is
//! a room and `walk_towards` otherwise, as in VirtualHome, where walking to a room enters it.

use grounding::Task;

use super::{Spelling, SurfaceLanguage};

/// EAI schema → VirtualHome verb.
pub const VERBS: &[(&str, &str)] = &[
    ("walk_towards", "walk"),
    ("walk_into", "walk"),
    ("find", "find"),
    ("sit", "sit"),
    ("standup", "standup"),
    ("grab", "grab"),
    ("open", "open"),
    ("close", "close"),
    ("put_on", "putback"),
    ("put_on_character", "puton"),
    ("put_inside", "putin"),
    ("switch_on", "switchon"),
    ("switch_off", "switchoff"),
    ("drink", "drink"),
    ("turn_to", "turnto"),
    ("look_at", "lookat"),
    ("wipe", "wipe"),
    ("drop", "drop"),
    ("read", "read"),
    ("touch", "touch"),
    ("lie", "lie"),
    ("pour", "pour"),
    ("type", "type"),
    ("watch", "watch"),
    ("move", "move"),
    ("wash", "wash"),
    ("squeeze", "squeeze"),
    ("plug_in", "plugin"),
    ("plug_out", "plugout"),
    ("cut", "cut"),
    ("eat", "eat"),
    ("sleep", "sleep"),
    ("wake_up", "wakeup"),
];

/// VirtualHome's room classes (EAI names its kitchen `dining_room` and its study `home_office`).
pub const ROOMS: &[&str] = &["bathroom", "bedroom", "kitchen", "livingroom", "living_room", "dining_room", "home_office"];

impl Spelling {
    /// VirtualHome class-level commands. Schemas missing from [`VERBS`] have no spelling.
    pub fn virtualhome(task: &Task) -> Spelling {
        let verbs: Vec<Option<&str>> =
            task.schemas.iter().map(|s| VERBS.iter().find(|(schema, _)| *schema == s.name).map(|(_, verb)| *verb)).collect();
        Spelling::from_fn(task, SurfaceLanguage::Virtualhome, |id| {
            let action = task.action(id);
            let schema = &task.schemas[action.schema.index()];
            let verb = verbs[action.schema.index()]?;
            let mut out = verb.to_string();
            for arg in &action.args {
                let object = &task.objects[arg.index()];
                if object.types.iter().any(|t| t == "character") {
                    continue;
                }
                out.push(' ');
                out.push_str(&object.name);
            }
            if verb == "walk" {
                let target = action.args.last().map(|a| task.objects[a.index()].name.as_str()).unwrap_or_default();
                let is_room = ROOMS.contains(&target);
                if is_room != (schema.name == "walk_into") {
                    return None;
                }
            }
            Some(out)
        })
    }
}
