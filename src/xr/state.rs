//! The OpenXR session lifecycle as a pure state machine (OpenXR 1.0 spec,
//! §9.3 "Session Lifecycle"): READY → xrBeginSession; STOPPING →
//! xrEndSession; EXITING and LOSS_PENDING → leave the loop (destroy the
//! session). Frames are waited, begun and ended only while the session is
//! running (between a successful xrBeginSession and xrEndSession).
//!
//! Kept free of OpenXR calls so every transition is unit-tested.

/// Mirror of `XrSessionState`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum SessionState {
    /// XR_SESSION_STATE_UNKNOWN (before the first event).
    Unknown,
    /// XR_SESSION_STATE_IDLE.
    Idle,
    /// XR_SESSION_STATE_READY.
    Ready,
    /// XR_SESSION_STATE_SYNCHRONIZED.
    Synchronized,
    /// XR_SESSION_STATE_VISIBLE.
    Visible,
    /// XR_SESSION_STATE_FOCUSED.
    Focused,
    /// XR_SESSION_STATE_STOPPING.
    Stopping,
    /// XR_SESSION_STATE_LOSS_PENDING.
    LossPending,
    /// XR_SESSION_STATE_EXITING.
    Exiting,
}

/// What the application must do after a state change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Nothing.
    None,
    /// Call xrBeginSession.
    Begin,
    /// Call xrEndSession.
    End,
    /// Leave the frame loop and destroy the session (EXITING).
    Exit,
    /// The session is being lost (LOSS_PENDING): leave and report it.
    Lost,
}

/// What to do when the user asks to quit (Ctrl-C, SIGTERM, frame or time
/// limit reached).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuitAction {
    /// Call xrRequestExitSession and keep running until EXITING.
    RequestExit,
    /// Leave now: the session is not running (or an exit is already asked).
    Leave,
    /// An exit was requested already; keep going until EXITING.
    Wait,
}

/// Tracks the session state and whether the session is running.
#[derive(Clone, Debug)]
pub struct SessionMachine {
    /// The latest state reported by the runtime.
    pub state: SessionState,
    /// Between xrBeginSession and xrEndSession.
    pub running: bool,
    /// xrRequestExitSession was called.
    pub exit_requested: bool,
    /// Every state seen, in order.
    pub history: Vec<SessionState>,
}

impl Default for SessionMachine {
    fn default() -> Self {
        SessionMachine {
            state: SessionState::Unknown,
            running: false,
            exit_requested: false,
            history: Vec::new(),
        }
    }
}

impl SessionMachine {
    /// Records a state change and returns the action it calls for.
    pub fn on_state(&mut self, state: SessionState) -> Action {
        self.state = state;
        self.history.push(state);
        match state {
            SessionState::Ready => Action::Begin,
            SessionState::Stopping => Action::End,
            SessionState::Exiting => Action::Exit,
            SessionState::LossPending => Action::Lost,
            SessionState::Unknown
            | SessionState::Idle
            | SessionState::Synchronized
            | SessionState::Visible
            | SessionState::Focused => Action::None,
        }
    }

    /// Records the outcome of an action the caller performed.
    pub fn performed(&mut self, action: Action) {
        match action {
            Action::Begin => self.running = true,
            Action::End | Action::Exit | Action::Lost => self.running = false,
            Action::None => {}
        }
    }

    /// What to do on a quit request.
    pub fn on_quit(&mut self) -> QuitAction {
        if self.exit_requested {
            QuitAction::Wait
        } else if self.running {
            self.exit_requested = true;
            QuitAction::RequestExit
        } else {
            QuitAction::Leave
        }
    }

    /// Whether frames must be waited, begun and ended now.
    pub fn frames_due(&self) -> bool {
        self.running
    }

    /// Whether the session reached FOCUSED at some point.
    pub fn was_focused(&self) -> bool {
        self.history.contains(&SessionState::Focused)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use SessionState::*;

    fn drive(states: &[SessionState]) -> (SessionMachine, Vec<Action>) {
        let mut m = SessionMachine::default();
        let mut actions = Vec::new();
        for &s in states {
            let a = m.on_state(s);
            m.performed(a);
            actions.push(a);
        }
        (m, actions)
    }

    #[test]
    fn normal_lifecycle_begins_then_ends_then_exits() {
        let (m, a) = drive(&[
            Idle,
            Ready,
            Synchronized,
            Visible,
            Focused,
            Visible,
            Synchronized,
            Stopping,
            Idle,
            Exiting,
        ]);
        assert_eq!(
            a,
            vec![
                Action::None,
                Action::Begin,
                Action::None,
                Action::None,
                Action::None,
                Action::None,
                Action::None,
                Action::End,
                Action::None,
                Action::Exit
            ]
        );
        assert!(!m.running);
        assert!(m.was_focused());
    }

    #[test]
    fn frames_are_due_only_while_running() {
        let mut m = SessionMachine::default();
        assert!(!m.frames_due());
        let a = m.on_state(Ready);
        assert!(!m.frames_due(), "not before xrBeginSession succeeded");
        m.performed(a);
        assert!(m.frames_due());
        for s in [Synchronized, Visible, Focused] {
            let a = m.on_state(s);
            m.performed(a);
            assert!(m.frames_due());
        }
        let a = m.on_state(Stopping);
        m.performed(a);
        assert!(!m.frames_due());
    }

    #[test]
    fn loss_pending_leaves_without_ending() {
        let (m, a) = drive(&[Idle, Ready, Focused, LossPending]);
        assert_eq!(a.last(), Some(&Action::Lost));
        assert!(!m.running);
    }

    #[test]
    fn quit_requests_exit_once_while_running_and_leaves_when_idle() {
        let mut m = SessionMachine::default();
        assert_eq!(m.on_quit(), QuitAction::Leave);
        let (mut m2, _) = drive(&[Idle, Ready, Focused]);
        assert_eq!(m2.on_quit(), QuitAction::RequestExit);
        assert_eq!(m2.on_quit(), QuitAction::Wait);
        m.exit_requested = false;
        assert_eq!(m.on_quit(), QuitAction::Leave);
    }
}
