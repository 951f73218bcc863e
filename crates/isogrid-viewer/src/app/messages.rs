//! Messages listed in the window, and failures, which end a scripted run but only show in an
//! interactive one.

use super::state::{App, Message, ScriptState};

impl App {
    /// Lists `text` in the window (errors also on stderr), keeping the last few.
    pub(super) fn note(&mut self, text: String, error: bool) {
        if self.messages.last().is_some_and(|m| m.text == text) {
            return;
        }
        if error {
            eprintln!("isogrid view: {text}");
        }
        self.messages.push(Message { text, error });
        let excess = self.messages.len().saturating_sub(8);
        self.messages.drain(..excess);
    }

    /// Stops a scripted run with `message`; an interactive run shows it.
    pub(super) fn fail(&mut self, message: String) {
        if let Some(script) = &mut self.script {
            if !matches!(script.state, ScriptState::Finished) {
                script.state = ScriptState::Finished;
                if let Ok(mut f) = self.failure.lock() {
                    f.get_or_insert(message.clone());
                }
            }
        }
        self.note(message, true);
    }

    /// What only degrades an interactive run (a mode replaced by another) but makes a scripted
    /// run's result wrong, so ends it.
    pub(super) fn fail_or_note(&mut self, message: String) {
        if self.script.is_some() {
            self.fail(message);
        } else {
            self.note(message, false);
        }
    }
}
