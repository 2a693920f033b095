//! The direct interactive policy with a scripted chat model standing in for a served one:
//! a scripted walkthrough wins ALFWorld games; a failed command's feedback reaches the next
//! prompt with an unchanged observation; DONE, the step limit and the failure threshold end
//! episodes with the right mechanism and attribution; unreadable replies and VirtualHome
//! instance-level lines never reach the environment; pictures are attached and counted; the
//! prompts show no hidden state (no instance the observations did not show, no admissible
//! list, no goal formula); the first prompts of one ALFWorld game and one rearrangement task
//! are snapshots.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use exploration_harness::direct::{self, DirectConfig, DirectEnd, DirectEpisode, FAILURE_LIMIT};
use exploration_harness::{Attribution, parse_goal, run_direct};
use household_sim::{
    AlfworldEnv, EngineLine, Environment, GoalAnnotation, Image, Judge, JudgeAtom, Observation, StepResult, VirtualhomeEnv, VirtualhomeTask,
};
use vlm_client::{ChatError, ChatModel, ChatReply, ChatRequest, Usage};

/// Replies from a list, then `otherwise` forever; keeps every request's text and picture count.
struct Scripted {
    replies: VecDeque<String>,
    otherwise: String,
    prompts: Vec<String>,
    images: Vec<usize>,
    usage: Usage,
}

impl Scripted {
    fn new(replies: impl IntoIterator<Item = String>, otherwise: String) -> Scripted {
        Scripted { replies: replies.into_iter().collect(), otherwise, prompts: Vec::new(), images: Vec::new(), usage: Usage::default() }
    }
}

impl ChatModel for Scripted {
    fn chat(&mut self, request: &ChatRequest) -> Result<ChatReply, ChatError> {
        let schema = request.json_schema.as_ref().expect("a reply schema");
        assert_eq!(schema["properties"]["action"]["type"], "string", "the action is a free string");
        assert_eq!(request.sampling.temperature, Some(0.0), "greedy");
        assert_eq!(request.sampling.max_tokens, Some(direct::MAX_REPLY_TOKENS));
        self.prompts.push(request.messages.iter().map(|m| m.joined_text()).collect::<Vec<_>>().join("\n"));
        self.images.push(request.image_count());
        let text = self.replies.pop_front().unwrap_or_else(|| self.otherwise.clone());
        let one = Usage { requests: 1, prompt_tokens: 100, completion_tokens: 20, reasoning_tokens: None, images: 0 };
        self.usage.add(&one);
        Ok(ChatReply::local(text, one))
    }

    fn endpoint(&self) -> String {
        "scripted".into()
    }

    fn usage(&self) -> Usage {
        self.usage
    }
}

fn act(command: &str) -> String {
    serde_json::json!({"action": command, "done": false}).to_string()
}

fn done() -> String {
    serde_json::json!({"action": "DONE", "done": true}).to_string()
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// The game the Phase I prompt snapshot uses too (clean a mug, put it in the coffee machine).
fn mug_game() -> PathBuf {
    fixtures()
        .join("alfworld/valid_seen/pick_clean_then_place_in_recep-Mug-None-CoffeeMachine-26/trial_T20190907_233056_022802/game.tw-pddl")
}

fn alfworld(game: &Path) -> AlfworldEnv {
    AlfworldEnv::from_game_file(game).unwrap()
}

fn rearrangement(task: &str) -> VirtualhomeEnv {
    let task = VirtualhomeTask::load(&fixtures().join(format!("virtualhome-rearrange/{task}.json.gz"))).unwrap();
    VirtualhomeEnv::new(task, "virtualhome-rearrange")
}

fn run<E: Environment + Judge>(env: &mut E, model: &mut Scripted, config: &DirectConfig) -> DirectEpisode {
    let goal = parse_goal(env.goal()).unwrap();
    run_direct(env, model, &goal, config).unwrap()
}

fn paper(benchmark: &str) -> DirectConfig {
    DirectConfig::paper(benchmark)
}

/// One game of every seventh task family in valid_seen.
fn some_games() -> Vec<PathBuf> {
    let root = fixtures().join("alfworld/valid_seen");
    let mut families: Vec<PathBuf> = std::fs::read_dir(&root).unwrap().map(|f| f.unwrap().path()).collect();
    families.sort();
    families
        .iter()
        .step_by(7)
        .map(|family| std::fs::read_dir(family).unwrap().next().unwrap().unwrap().path().join("game.tw-pddl"))
        .collect()
}

#[test]
fn the_walkthrough_replied_one_command_a_turn_wins() {
    let games = some_games();
    assert!(games.len() >= 4);
    for game in games {
        let mut env = alfworld(&game);
        let walkthrough = env.walkthrough().to_vec();
        let mut model = Scripted::new(walkthrough.iter().map(|c| act(c)), done());
        let episode = run(&mut env, &mut model, &paper("alfworld"));
        let name = game.display();
        assert!(episode.success, "{name}: {episode:?}");
        assert_eq!(episode.end, DirectEnd::Success, "{name}");
        assert_eq!(episode.attribution, None, "{name}");
        assert!(episode.unmet_goals.is_empty(), "{name}");
        assert!(episode.steps.iter().all(|s| s.executed && s.sent), "{name}");
        let commands: Vec<&str> = episode.steps.iter().map(|s| s.command.as_str()).collect();
        assert_eq!(commands, walkthrough[..commands.len()].iter().map(String::as_str).collect::<Vec<_>>(), "{name}");
        let turns = episode.steps.len() as u64;
        assert_eq!(episode.usage.model_calls, turns, "{name}");
        assert_eq!(episode.usage.generated_tokens, 20 * turns, "{name}");
        assert_eq!(episode.usage.prompt_tokens, 100 * turns, "{name}");
        assert_eq!(episode.usage.observations, turns, "{name}");
        assert_eq!(episode.usage.images, 0, "{name}");
        assert_eq!(model.prompts.len() as u64, turns, "{name}");
        assert_eq!(env.steps_taken() as u64, turns, "{name}");
        assert!(episode.requests().iter().all(|(_, executed)| *executed));
        // The record replays in the real engine: every command as sent, with its outcome.
        let script: Vec<(&str, bool)> = episode.engine_script.iter().map(|l| (l.line.as_str(), l.executed)).collect();
        assert_eq!(script, episode.requests(), "{name}");
    }
}

#[test]
fn a_wrong_command_is_told_in_the_next_prompt_with_an_unchanged_view() {
    let mut env = alfworld(&mug_game());
    let first = env.reset();
    let walkthrough = env.walkthrough().to_vec();
    let wrong = "take unicorn 1 from countertop 1";
    let mut model = Scripted::new(std::iter::once(act(wrong)).chain(walkthrough.iter().map(|c| act(c))), done());
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert!(episode.success, "{episode:?}");
    let step = &episode.steps[0];
    assert!(!step.executed && step.sent);
    assert_eq!(step.command, wrong);
    assert_eq!(step.reason.as_deref(), Some(household_sim::NOTHING_HAPPENS));
    assert_eq!(step.observation, first.text, "the view did not change");
    let second = &model.prompts[1];
    assert!(second.contains(&direct::failure_feedback(wrong, household_sim::NOTHING_HAPPENS)), "{second}");
    assert!(second.contains("could not be executed: Nothing happens (invalid or unreachable)"), "{second}");
    assert!(second.contains(&format!("1. {wrong} -> failed (invalid or unreachable)")), "{second}");
    assert!(second.contains(first.text.trim()), "the unchanged observation is shown again: {second}");
    let third = &model.prompts[2];
    assert!(third.contains(direct::SUCCESS_FEEDBACK), "{third}");
    assert!(third.contains(&format!("2. {} -> success", walkthrough[0])), "{third}");
    assert!(model.prompts[0].contains(direct::FIRST_FEEDBACK));
    assert_eq!(episode.steps.len(), 1 + walkthrough.len().min(episode.steps.len() - 1));
}

#[test]
fn done_ends_the_episode_without_sending_anything() {
    let mut env = alfworld(&mug_game());
    let walkthrough = env.walkthrough().to_vec();
    let mut model = Scripted::new([act(&walkthrough[0]), done()], act("look"));
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.end, DirectEnd::Done);
    assert!(episode.model_done());
    assert!(!episode.success);
    assert_eq!(episode.attribution, Some(Attribution::Goal), "a premature DONE is `goal not reached`");
    assert_eq!(episode.steps.len(), 1);
    assert_eq!(env.steps_taken(), 1);
    assert_eq!(episode.usage.model_calls, 2);
    assert!(!episode.unmet_goals.is_empty());

    // `done` with an action is DONE too: the action is not executed.
    let mut env = alfworld(&mug_game());
    let reply = serde_json::json!({"action": walkthrough[0], "done": true}).to_string();
    let mut model = Scripted::new([reply], act("look"));
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!((episode.end, episode.steps.len(), env.steps_taken()), (DirectEnd::Done, 0, 0));

    // `DONE` in any case, with done false.
    let mut env = alfworld(&mug_game());
    let mut model = Scripted::new([act("done")], act("look"));
    assert_eq!(run(&mut env, &mut model, &paper("alfworld")).end, DirectEnd::Done);
}

#[test]
fn the_step_limit_ends_the_episode() {
    let mut env = alfworld(&mug_game());
    let mut model = Scripted::new([], act("look"));
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.end, DirectEnd::Limit);
    assert_eq!(episode.steps.len(), 55);
    assert!(episode.steps.iter().all(|s| s.executed));
    assert_eq!(episode.attribution, Some(Attribution::Goal));
    assert_eq!(model.prompts.len(), 55);

    let mut env = rearrangement("dishwasher-000");
    let rooms = ["walk bathroom", "walk bedroom"];
    let mut model = Scripted::new((0..40).map(|i| act(rooms[i % 2])), done());
    let episode = run(&mut env, &mut model, &paper("virtualhome-rearrange"));
    assert_eq!(episode.end, DirectEnd::Limit);
    assert_eq!(episode.steps.len(), 20);
    assert!(episode.steps.iter().all(|s| s.executed), "{:?}", episode.steps.iter().find(|s| !s.executed));
}

#[test]
fn failed_turns_in_a_row_end_the_episode_as_grounding() {
    let mut env = alfworld(&mug_game());
    let mut model = Scripted::new([], act("fly to the moon"));
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.end, DirectEnd::Failures);
    assert_eq!(episode.steps.len(), FAILURE_LIMIT);
    assert_eq!(episode.attribution, Some(Attribution::Grounding));
    assert!(episode.steps.iter().all(|s| s.sent && !s.executed));

    // An executed step starts the count again.
    let mut env = alfworld(&mug_game());
    let bad = act("fly to the moon");
    let mut replies = vec![bad.clone(); FAILURE_LIMIT - 1];
    replies.push(act("look"));
    let mut model = Scripted::new(replies, bad);
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.end, DirectEnd::Failures);
    assert_eq!(episode.steps.len(), 2 * FAILURE_LIMIT);

    // When the budget runs out on the threshold's step, the limit ended it (as the terminal
    // mechanism counts it).
    let mut env = alfworld(&mug_game());
    let mut model = Scripted::new([], act("fly to the moon"));
    let config = DirectConfig { budget: FAILURE_LIMIT, ..paper("alfworld") };
    let episode = run(&mut env, &mut model, &config);
    assert_eq!((episode.end, episode.attribution), (DirectEnd::Limit, Some(Attribution::Goal)));
}

#[test]
fn unreadable_replies_are_failed_turns_that_send_nothing() {
    let mut env = alfworld(&mug_game());
    // The reply and its repair turn both hold no JSON; then an object without the action.
    let replies = ["go to fridge 1".to_string(), "I would go to the fridge".to_string(), "{\"done\": false}".into(), "{}".into()];
    let mut model = Scripted::new(replies, done());
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.end, DirectEnd::Done);
    assert_eq!(episode.steps.len(), 2);
    for step in &episode.steps {
        assert!(!step.sent && !step.executed && step.command.is_empty(), "{step:?}");
        assert!(step.reason.as_deref().is_some_and(|r| r.starts_with("the reply could not be read")), "{step:?}");
    }
    assert_eq!(env.steps_taken(), 0);
    assert_eq!(episode.usage.model_calls, 5, "two repaired turns and the DONE");
    assert_eq!(episode.usage.generated_tokens, 5 * 20);
    let third = &model.prompts[4];
    assert!(third.contains("Your reply could not be read as an action"), "{third}");
    assert!(third.contains("2. (unreadable reply) -> failed (invalid or unreachable)"), "{third}");
}

#[test]
fn virtualhome_takes_class_level_commands_only() {
    let mut env = rearrangement("dishwasher-000");
    let mut model = Scripted::new([act("[WALK] <dining_room> (201)"), act("walk dining_room")], done());
    let episode = run(&mut env, &mut model, &paper("virtualhome-rearrange"));
    assert_eq!(episode.steps.len(), 2);
    assert!(!episode.steps[0].sent && !episode.steps[0].executed);
    assert!(episode.steps[1].sent && episode.steps[1].executed, "{:?}", episode.steps[1]);
    assert_eq!(env.steps_taken(), 1);
    assert!(model.prompts[1].contains("without instance numbers"), "{}", model.prompts[1]);
    // What the executor is given to replay the episode: the line the class-level walk was
    // grounded to; the refused instance-level line never reached it.
    assert_eq!(episode.engine_script, vec![EngineLine { line: "[WALK] <dining_room> (201)".into(), executed: true }]);

    // A class the agent cannot see from here: the environment's own reason comes back.
    let mut env = rearrangement("dishwasher-000");
    let mut model = Scripted::new([act("open dishwasher")], done());
    let episode = run(&mut env, &mut model, &paper("virtualhome-rearrange"));
    assert!(!episode.steps[0].executed && episode.steps[0].sent);
    assert!(model.prompts[1].contains("could not be grounded from this pose (invalid or unreachable)"), "{}", model.prompts[1]);
}

/// An ALFWorld game that renders a (tiny) picture with every observation.
struct Pictured(AlfworldEnv);

fn picture() -> Image {
    let png = vlm_client::Image::encode_rgb8(vlm_client::ImageFormat::Png, 2, 2, &[120; 12]).expect("png");
    Image { mime: "image/png", bytes: png.bytes().to_vec() }
}

impl Environment for Pictured {
    fn reset(&mut self) -> Observation {
        Observation { image: Some(picture()), ..self.0.reset() }
    }
    fn step(&mut self, command: &str) -> StepResult {
        let mut result = self.0.step(command);
        result.observation.image = Some(picture());
        result
    }
    fn goal_reached(&self) -> bool {
        self.0.goal_reached()
    }
    fn done(&self) -> bool {
        self.0.done()
    }
    fn steps_taken(&self) -> usize {
        self.0.steps_taken()
    }
    fn goal(&self) -> &GoalAnnotation {
        self.0.goal()
    }
}

impl Judge for Pictured {
    fn hidden_atoms(&self) -> Vec<JudgeAtom> {
        self.0.hidden_atoms()
    }
    fn unmet_goals(&self) -> Vec<String> {
        self.0.unmet_goals()
    }
    fn engine_script(&self) -> Vec<EngineLine> {
        self.0.engine_script()
    }
    fn admissible_commands(&self) -> Option<Vec<String>> {
        self.0.admissible_commands()
    }
}

#[test]
fn the_current_picture_goes_with_every_request() {
    let mut env = Pictured(alfworld(&mug_game()));
    let mut model = Scripted::new([act("look"), act("fly"), act("look")], done());
    let episode = run(&mut env, &mut model, &paper("alfworld"));
    assert_eq!(episode.usage.images, 4);
    assert_eq!(episode.usage.observations, 4);
    assert_eq!(model.images, vec![1, 1, 1, 1]);
    assert!(model.prompts[0].contains("Use the first-person image and the observation"), "{}", model.prompts[0]);
}

/// Every `<class> <number>` instance name of the game (from the judge, evaluation only) that
/// occurs in `text` as a whole name (`mug 1` is not found in `mug 10`).
fn instance_names_in(text: &str, names: &[String]) -> Vec<String> {
    names
        .iter()
        .filter(|name| {
            text.match_indices(name.as_str()).any(|(at, _)| {
                let before = text[..at].chars().next_back().is_none_or(|c| !c.is_alphanumeric());
                let after = text[at + name.len()..].chars().next().is_none_or(|c| !c.is_ascii_digit());
                before && after
            })
        })
        .cloned()
        .collect()
}

#[test]
fn alfworld_prompts_show_only_what_the_observations_showed() {
    for game in some_games() {
        let mut env = alfworld(&game);
        let goal = parse_goal(env.goal()).unwrap();
        let mut names: Vec<String> = env.hidden_atoms().iter().flat_map(|a| a.args.clone()).filter(|a| a.contains(' ')).collect();
        names.sort();
        names.dedup();
        let first = env.reset();
        let admissible = env.admissible_commands().unwrap();
        let walkthrough = env.walkthrough().to_vec();
        // Half the walkthrough, a wrong command naming a real but unseen instance, then looks.
        let unseen = names.iter().find(|n| !first.text.contains(n.as_str())).cloned().unwrap_or_else(|| "unicorn 1".into());
        let sent = format!("take {unseen} from countertop 1");
        let replies = walkthrough.iter().take(walkthrough.len() / 2).map(|c| act(c)).chain([act(&sent)]);
        let mut model = Scripted::new(replies, act("look"));
        let config = DirectConfig { budget: 12, ..paper("alfworld") };
        let episode = run_direct(&mut env, &mut model, &goal, &config).unwrap();
        let mut shown = first.text.clone();
        for (i, prompt) in model.prompts.iter().enumerate() {
            let commands: String = episode.steps[..i].iter().map(|s| format!("{}\n", s.command)).collect();
            for name in instance_names_in(prompt, &names) {
                let seen = !instance_names_in(&shown, std::slice::from_ref(&name)).is_empty()
                    || !instance_names_in(&commands, std::slice::from_ref(&name)).is_empty();
                assert!(seen, "{}: prompt {i} names {name}, which no observation showed:\n{prompt}", game.display());
            }
            // Instance-level admissible commands (the list's `look` and `inventory` are forms).
            for command in admissible.iter().filter(|c| c.chars().any(|c| c.is_ascii_digit())) {
                assert!(
                    !prompt.contains(command.as_str()) || commands.contains(command.as_str()),
                    "{}: prompt {i} lists the admissible command {command}",
                    game.display()
                );
            }
            assert!(!prompt.contains(&env.goal().formula), "the goal formula is the judge's");
            if let Some(step) = episode.steps.get(i) {
                shown.push_str(&step.observation);
            }
        }
    }
}

#[test]
fn virtualhome_prompts_name_only_instances_the_observations_showed() {
    let mut env = rearrangement("dishwasher-000");
    let goal = parse_goal(env.goal()).unwrap();
    let first = env.reset();
    let script = ["walk kitchen", "walk dishwasher", "open dishwasher", "walk fork", "grab fork", "walk dining_room", "walk fork"];
    let mut model = Scripted::new(script.iter().map(|c| act(c)), act("walk bathroom"));
    let config = DirectConfig { budget: 10, ..paper("virtualhome-rearrange") };
    let episode = run_direct(&mut env, &mut model, &goal, &config).unwrap();
    let numbers = |text: &str| -> Vec<String> {
        let mut out = Vec::new();
        for (at, _) in text.match_indices('(') {
            let digits: String = text[at + 1..].chars().take_while(char::is_ascii_digit).collect();
            if !digits.is_empty() && text[at + 1 + digits.len()..].starts_with(')') {
                out.push(format!("({digits})"));
            }
        }
        out
    };
    let mut shown = first.text.clone();
    for (i, prompt) in model.prompts.iter().enumerate() {
        for id in numbers(prompt) {
            assert!(shown.contains(&id), "prompt {i} names {id}, which no observation showed:\n{prompt}");
        }
        assert!(!prompt.contains(&env.goal().formula));
        for atom in env.hidden_atoms() {
            assert!(!prompt.contains(&atom.to_string()), "prompt {i} holds the hidden atom {atom}");
        }
        if let Some(step) = episode.steps.get(i) {
            shown.push_str(&step.observation);
        }
    }
}

#[test]
fn the_first_prompt_of_an_alfworld_game() {
    let mut env = alfworld(&mug_game());
    let mut model = Scripted::new([done()], done());
    run(&mut env, &mut model, &paper("alfworld"));
    insta::assert_snapshot!(model.prompts[0]);
}

#[test]
fn the_first_prompt_of_a_rearrangement_task() {
    let mut env = rearrangement("dishwasher-000");
    let mut model = Scripted::new([done()], done());
    run(&mut env, &mut model, &paper("virtualhome-rearrange"));
    insta::assert_snapshot!(model.prompts[0]);
}

#[test]
fn eai_tasks_list_every_executor_action_once() {
    let forms = direct::action_forms("virtualhome-eai");
    assert!(forms.contains(&"switchon <object>".to_string()), "{forms:?}");
    assert!(forms.contains(&"putin <object> <object>".to_string()));
    assert!(forms.contains(&"standup".to_string()));
    assert_eq!(forms.last().map(String::as_str), Some("DONE"));
    let mut unique = forms.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(unique.len(), forms.len());
    assert_eq!(direct::action_forms("virtualhome-rearrange").len(), 7);
}
