//! The shore link's part of `report.json` (`shore_link`), read back from
//! what the run wrote: the bridge's `link.jsonl` (link changes, commands as
//! forwarded and acknowledged) and the planner's `mission.log` (each
//! command as the planner applied or refused it).

use std::path::Path;

use serde_json::{Value, json};

/// The `shore_link` object: endpoint, link losses with their detection
/// time, restorations, restarts of the link process, and commands.
pub fn shore_link_json(out: &Path, endpoint: &str, timeout_ms: u64, restarts: u64) -> Value {
    let read = |name: &str| std::fs::read_to_string(out.join(name)).unwrap_or_default();
    let lines = |text: String| -> Vec<Value> { text.lines().filter_map(|l| serde_json::from_str(l).ok()).collect() };
    let link = lines(read("link.jsonl"));
    let log = lines(read("mission.log"));
    let of = |v: &[Value], e: &str| -> Vec<Value> { v.iter().filter(|l| l["event"] == e).cloned().collect() };
    let detect: Vec<f64> = of(&link, "link_lost")
        .iter()
        .filter_map(|l| l["silent_ms"].as_f64())
        .collect();
    let commands = of(&log, "command");
    let first = |status: &str| {
        commands
            .iter()
            .filter(|c| c["status"] == status && c["repeat"] == false)
            .count()
    };
    let mut refused_by = serde_json::Map::new();
    for c in commands
        .iter()
        .filter(|c| c["status"] == "refused" && c["repeat"] == false)
    {
        let r = c["reason"].as_str().unwrap_or("unknown").to_string();
        let n = refused_by.get(&r).and_then(Value::as_u64).unwrap_or(0);
        refused_by.insert(r, json!(n + 1));
    }
    // Refused by the bridge before reaching the planner (unknown waypoint…).
    let bridge_refused = of(&link, "command_ack")
        .iter()
        .filter(|a| a["status"] == "refused" && a["plan_seq"] == 0)
        .filter(|a| !commands.iter().any(|c| c["id"] == a["id"]))
        .count();
    json!({
        "endpoint": endpoint,
        "timeout_ms": timeout_ms,
        "link_starts": of(&link, "link_start").len(),
        "link_restarts": restarts,
        "connected": of(&link, "link_connected").len(),
        "losses": detect.len(),
        "restores": of(&link, "link_restored").len(),
        "detect_ms": detect,
        "detect_ms_max": detect.iter().copied().fold(0.0, f64::max),
        "commands": {
            "applied": first("applied"),
            "refused": first("refused") + bridge_refused,
            "refused_by_planner": refused_by,
            "refused_by_link": bridge_refused,
            "repeats": commands.iter().filter(|c| c["repeat"] == true).count(),
        },
    })
}

/// One summary line of the `shore_link` object.
pub fn summary_line(v: &Value) -> String {
    format!(
        "shore link {}: lost {} times (detected after at most {:.0} ms), restored {}, restarted {}; commands applied {}, refused {}",
        v["endpoint"].as_str().unwrap_or("?"),
        v["losses"],
        v["detect_ms_max"].as_f64().unwrap_or(0.0),
        v["restores"],
        v["link_restarts"],
        v["commands"]["applied"],
        v["commands"]["refused"],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn losses_and_commands_are_counted_from_the_run_files() {
        let dir = std::env::temp_dir().join(auv_transport::unique_prefix("shrep"));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("link.jsonl"),
            concat!(
                "{\"event\":\"link_start\"}\n",
                "{\"event\":\"link_connected\"}\n",
                "{\"event\":\"link_lost\",\"silent_ms\":1003.5}\n",
                "{\"event\":\"link_restored\",\"down_ms\":2500}\n",
                "{\"event\":\"command_ack\",\"id\":9,\"status\":\"refused\",\"plan_seq\":0}\n",
            ),
        )
        .unwrap();
        std::fs::write(
            dir.join("mission.log"),
            concat!(
                "{\"event\":\"command\",\"id\":1,\"status\":\"applied\",\"reason\":\"none\",\"repeat\":false}\n",
                "{\"event\":\"command\",\"id\":1,\"status\":\"applied\",\"reason\":\"none\",\"repeat\":true}\n",
                "{\"event\":\"command\",\"id\":2,\"status\":\"refused\",\"reason\":\"no_change\",\"repeat\":false}\n",
            ),
        )
        .unwrap();
        let v = shore_link_json(&dir, "tcp/127.0.0.1:1", 1000, 1);
        assert_eq!(v["losses"], 1);
        assert_eq!(v["detect_ms_max"], 1003.5);
        assert_eq!(v["restores"], 1);
        assert_eq!(v["commands"]["applied"], 1);
        assert_eq!(v["commands"]["refused"], 2);
        assert_eq!(v["commands"]["refused_by_planner"]["no_change"], 1);
        assert_eq!(v["commands"]["repeats"], 1);
        assert!(summary_line(&v).contains("lost 1 times"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
