"""The studio in a real headless Chromium, offline, driven with real pointer events.

From an empty canvas the test drags the paper's gathering tree (Fig. 6) block by block out
of the toolbox (Selenium's pointer actions), types on each block the name the packaged
gathering tree gives that node, runs it, saves the run (8000 iterations, seed 0), and
checks: the saved states equal ``pyaa run gathering --seed 0`` bit for bit in every column
(``behaviour``, the active leaf's name, included) and ``pyaa run gathering --tree SAVED.xml
--seed 0``; the saved XML loads in ``pyaa run --tree`` and in the real BehaviorTree.CPP
(behaviortreepy). A second test builds an invalid tree and sees the block's message, with
Run disabled.

Needs Debian's ``chromium`` and ``chromium-driver``, selenium, and the built front-end
(``make test`` builds it); skipped, with the reason, without them.
"""

from __future__ import annotations

import html
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from pyautonomousagent.bt.files import load_tree, read_document
from pyautonomousagent.bt.spec import snake_case
from pyautonomousagent.cli import main
from pyautonomousagent.recording import read_table
from pyautonomousagent.scenarios import load
from pyautonomousagent.studio import Studio, has_bundle
from pyautonomousagent.studio.trees import blocks_of
from tests.chromium import offline_chromium

GATHERING = (
    "ReactiveSequence", [
        ("Action_Transmit_Shared_Data_S", []),
        ("ReactiveFallback", [
            ("Sequence", [
                ("Condition_Gathering_Moment", []),
                ("Action_Transmit_Gathering_Message_S", []),
            ]),
            ("Sequence", [
                ("Condition_Low_Energy_Level", []),
                ("Action_Set_Destination_Equal_To_Refueling_S", []),
                ("Fallback", [
                    ("ReactiveSequence", [
                        ("Inverter", [("Condition_Destination_Reached", [])]),
                        ("Action_Navigate_To_Destination_A", []),
                    ]),
                    ("Sequence", [
                        ("Action_Refuel_A", []),
                        ("Action_Set_Destination_Equal_To_Surveillance_S", []),
                    ]),
                ]),
            ]),
            ("Action_Navigate_To_Destination_A", []),
        ]),
    ],
)  # fmt: skip
"""The paper's gathering tree (Fig. 6): node type, children."""
DECORATORS = {"Inverter"}


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if not has_bundle():
        pytest.skip("the studio's front-end is not built: cd studio && npm ci && npm run build")
    with offline_chromium(1500, 2000) as driver:
        yield driver


def wait_for(check: Callable[[], Any], seconds: float = 20.0) -> Any:
    """``check()``'s first truthy value within ``seconds``; fails the test otherwise."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"not reached in {seconds} s: {check}")


def open_empty(browser: Any, studio: Studio) -> None:
    browser.get(studio.url)
    wait_for(lambda: browser.execute_script("return !!window.studio"))
    browser.find_element("id", "start-empty").click()
    wait_for(lambda: "empty" in browser.find_element("id", "message").text)


def drag(browser: Any, start: dict[str, float], end: dict[str, float]) -> bool:
    """Press at ``start`` and move toward ``end`` (viewport pixels), then move so that the
    dragged block's connection lands on ``end``, and release: real pointer events, as a
    mouse makes them. False if no block was dragged (the pointer is released)."""
    from selenium.webdriver.common.action_chains import ActionChains

    press = ActionChains(browser)
    pointer = press.w3c_actions.pointer_action
    pointer.move_to_location(int(start["x"]), int(start["y"]))
    pointer.pointer_down()
    x, y = start["x"], start["y"]
    for k in range(1, 9):
        x = start["x"] + (end["x"] + 40 - start["x"]) * k / 8
        y = start["y"] + (end["y"] + 40 - start["y"]) * k / 8
        pointer.move_to_location(int(x), int(y))
    press.perform()
    try:
        corner = wait_for(lambda: browser.execute_script("return window.studio.dragged()"), 3)
    except AssertionError:
        corner = None
    release = ActionChains(browser)
    pointer = release.w3c_actions.pointer_action
    if corner is not None:
        pointer.move_to_location(int(x + end["x"] - corner["x"]), int(y + end["y"] - corner["y"]))
        pointer.pause(0.1)
    pointer.pointer_up()
    release.perform()
    return corner is not None


def open_category(browser: Any, category: str) -> None:
    """Open a toolbox category (a click on the open one would close it)."""
    script = "return window.studio.openCategory()"
    for _ in range(3):
        if browser.execute_script(script) == category:
            return
        browser.find_element("id", category).click()
    assert browser.execute_script(script) == category


def add_block(browser: Any, kind: str, parent: str | None) -> str:
    """Open the toolbox category of ``kind``, drag its block under ``parent`` (None: the
    Tree block) as the last child; the new block's id. Each drag starts once the page has
    checked the tree (a check may show or hide warnings, which moves blocks)."""
    category = "cat-mission"
    if not kind.startswith(("Action_", "Condition_")):
        category = "cat-decorators" if kind in DECORATORS else "cat-control"
    block_type = f"bt_{kind}"
    newest = "return window.studio.newest(arguments[0])"
    for _ in range(3):
        wait_for(lambda: not browser.execute_script("return window.studio.busy()"))
        open_category(browser, category)
        start = wait_for(lambda: browser.execute_script(
            "try { return window.studio.flyoutBlock(arguments[0]); } catch (e) { return null; }",
            block_type))  # fmt: skip
        end = browser.execute_script("return window.studio.dropPoint(arguments[0])", parent)
        before = browser.execute_script(newest, block_type)
        if drag(browser, {"x": start["x"] + 12, "y": start["y"] + 8}, end):
            return wait_for(
                lambda before=before: (
                    (made := browser.execute_script(newest, block_type)) != before and made
                )
            )
    raise AssertionError(f"no {kind} block could be dragged out of the toolbox")


def rename(browser: Any, block: str, name: str) -> None:
    """Click the block's name field (a real click) and type ``name`` over it, then Enter."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    point = browser.execute_script("return window.studio.nameField(arguments[0])", block)
    click = ActionChains(browser)
    click.w3c_actions.pointer_action.move_to_location(int(point["x"]), int(point["y"]))
    click.w3c_actions.pointer_action.click()
    click.perform()
    editor = wait_for(lambda: browser.execute_script(
        "const e = document.activeElement;"
        "return e && e.classList.contains('blocklyHtmlInput') ? e : null"), 5)  # fmt: skip
    editor.send_keys(Keys.CONTROL, "a")
    editor.send_keys(name, Keys.ENTER)
    wait_for(lambda: browser.execute_script("return window.studio.name(arguments[0])", block)
             == name, 5)  # fmt: skip


def follow_agent(browser: Any, row: int) -> None:
    """Click drone ``row`` (0-based) on the map with a real pointer; wait until it is
    followed."""
    from selenium.webdriver.common.action_chains import ActionChains

    point = browser.execute_script(f"return window.studio.agentPoint({row})")
    click = ActionChains(browser)
    click.w3c_actions.pointer_action.move_to_location(int(point["x"]), int(point["y"]))
    click.w3c_actions.pointer_action.click()
    click.perform()
    wait_for(lambda: f"following drone{row + 1}" in browser.find_element("id", "follow").text)


def build(browser: Any, node: dict[str, Any], parent: str | None = None) -> None:
    """Drag ``node`` (a tree of blocks: type, name, children) under ``parent`` block by
    block; each new block starts with its type's name, and ``node``'s name is typed over it."""
    made = add_block(browser, node["type"], parent)
    name = "return window.studio.name(arguments[0])"
    assert browser.execute_script(name, made) == snake_case(node["type"])
    rename(browser, made, node["name"])
    for child in node["children"]:
        build(browser, child, made)


def shape(tree: dict[str, Any]) -> tuple[str, list]:
    return (tree["type"], [shape(child) for child in tree["children"]])


def names_of(tree: dict[str, Any]) -> list[str]:
    return [tree["name"], *(n for child in tree["children"] for n in names_of(child))]


def packaged_gathering() -> dict[str, Any]:
    """The packaged gathering tree as blocks (type, name, ports, children)."""
    return blocks_of(read_document(load("gathering").tree))


def test_build_the_gathering_tree_from_blocks_run_and_save(
    browser: Any, studio: Studio, tmp_path: Path
) -> None:
    open_empty(browser, studio)
    assert browser.find_element("id", "play").get_attribute("disabled")
    paper = packaged_gathering()
    assert shape(paper) == GATHERING
    build(browser, paper)
    made = browser.execute_script("return window.studio.tree()")
    assert shape(made) == GATHERING and names_of(made) == names_of(paper)
    wait_for(lambda: not browser.execute_script("return window.studio.busy()"))
    wait_for(lambda: browser.execute_script("return window.studio.runnable()"))
    assert not browser.find_element("id", "play").get_attribute("disabled")
    browser.find_element("id", "step").click()
    wait_for(lambda: "iteration 1 of 8000" in browser.find_element("id", "iteration").text)
    name = browser.find_element("id", "name")
    name.clear()
    name.send_keys("fig6")
    browser.find_element("id", "save-run").click()
    wait_for(lambda: "saved runs/fig6" in browser.find_element("id", "message").text, 300)
    saved = tmp_path / "fig6.xml"
    ours = read_table(tmp_path / "runs/fig6/states.parquet")
    assert ours.num_rows == 4 * 8001
    out = tmp_path / "cli-tree"
    assert main(["run", "gathering", "--tree", str(saved), "--seed", "0", "--out", str(out),
                 "--no-gif", "--quiet"]) == 0  # fmt: skip
    assert ours.equals(read_table(out / "states.parquet"))
    cli = tmp_path / "cli-paper"
    args = ["run", "gathering", "--seed", "0", "--out", str(cli), "--no-gif", "--quiet"]
    assert main(args) == 0
    theirs = read_table(cli / "states.parquet")
    assert ours.column_names == theirs.column_names and "behaviour" in ours.column_names
    for column in ours.column_names:  # every column, behaviour (the active leaf) included
        assert ours.column(column).equals(theirs.column(column)), column
    assert ours.equals(theirs)
    assert load_tree(saved).walk() is not None
    btcpp = pytest.importorskip("behaviortreepy", reason="behaviortreepy is not installed")
    from .btcpp_reference import btcpp_factory_with_our_leaves, btcpp_text

    del btcpp
    factory = btcpp_factory_with_our_leaves()
    assert factory.create_tree_from_text(btcpp_text(saved.read_text())).root_node() is not None


def test_an_invalid_tree_shows_the_message_on_the_block_and_cannot_run(
    browser: Any, studio: Studio, tmp_path: Path
) -> None:
    open_empty(browser, studio)
    inverter = add_block(browser, "Inverter", None)
    add_block(browser, "Condition_Low_Energy_Level", inverter)
    add_block(browser, "Action_Refuel_A", inverter)
    message = wait_for(
        lambda: (
            "needs exactly 1 child" in (text := browser.find_element("id", "message").text) and text
        )
    )
    assert "decorator Inverter needs exactly 1 child, has 2" in message
    warning = browser.execute_script("return window.studio.warning(arguments[0])", inverter)
    assert "needs exactly 1 child" in (warning or "")
    for button in ("play", "step", "reset", "save-run"):
        assert browser.find_element("id", button).get_attribute("disabled")
    assert list(tmp_path.iterdir()) == []
    # Undo (Ctrl+Z, Blockly's) takes the second child out: the tree can run; redo puts it back.
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    def keys(*held: str) -> None:
        chain = ActionChains(browser)
        for key in held:
            chain.key_down(key)
        chain.send_keys("z")
        for key in reversed(held):
            chain.key_up(key)
        chain.perform()

    keys(Keys.CONTROL)
    wait_for(lambda: "can run (2 nodes)" in browser.find_element("id", "message").text)
    assert not browser.find_element("id", "play").get_attribute("disabled")
    keys(Keys.CONTROL, Keys.SHIFT)
    wait_for(lambda: "needs exactly 1 child" in browser.find_element("id", "message").text)
    assert browser.find_element("id", "play").get_attribute("disabled")


def test_a_files_node_names_are_kept_and_a_new_block_takes_its_types_name(
    browser: Any, studio: Studio, tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    tree = "return window.studio.tree()"
    browser.get(studio.url)
    wait_for(lambda: "can run" in browser.find_element("id", "message").text)
    assert names_of(browser.execute_script(tree)) == names_of(packaged_gathering())
    upload = tmp_path_factory.mktemp("uploads") / "renamed.xml"
    text = Path(load("gathering").tree).read_text(encoding="utf-8")
    markup = '<img src=x onerror="window.pwned=1">'  # a name is text, never markup
    text = text.replace('"sequence_refuel"', '"refuel_then_go_back"')
    text = text.replace('"sequence_gathering"', f'"{html.escape(markup)}"')
    upload.write_text(text, "utf-8")
    browser.find_element("id", "upload").send_keys(str(upload))
    wait_for(lambda: "refuel_then_go_back" in names_of(browser.execute_script(tree)))
    assert len(names_of(browser.execute_script(tree))) == 18
    assert markup in names_of(browser.execute_script(tree))
    wait_for(lambda: not browser.execute_script("return window.studio.busy()"))  # checked
    wait_for(lambda: browser.execute_script("return window.studio.runnable()"))
    browser.find_element("id", "reset").click()
    browser.find_element("id", "step").click()
    wait_for(lambda: markup in browser.find_element("id", "nodes").text)
    assert browser.execute_script("return window.pwned") is None
    open_empty(browser, studio)
    sequence = add_block(browser, "Sequence", None)
    first = add_block(browser, "Action_Refuel_A", sequence)
    second = add_block(browser, "Action_Refuel_A", sequence)
    made = ["sequence", "action_refuel_a", "action_refuel_a_2"]
    assert names_of(browser.execute_script(tree)) == made
    wait_for(lambda: browser.execute_script("return window.studio.runnable()"))
    rename(browser, second, "action_refuel_a")  # two nodes of one name: the loader refuses
    wait_for(lambda: "two nodes are named" in browser.find_element("id", "message").text)
    assert "two nodes are named 'action_refuel_a'" in (
        browser.execute_script("return window.studio.warning(arguments[0])", second) or ""
    )
    assert browser.find_element("id", "save-xml").get_attribute("disabled")
    rename(browser, first, "refuel_first")
    wait_for(lambda: browser.execute_script("return window.studio.runnable()"))
    browser.find_element("id", "save-xml").click()
    wait_for(lambda: "wrote studio.xml" in browser.find_element("id", "message").text)
    saved = [node.name for node in load_tree(tmp_path / "studio.xml").walk()]
    assert saved == ["sequence", "refuel_first", "action_refuel_a"]
    # a copy (Ctrl+C, Ctrl+V) of a block takes the next free name of its original's
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    point = browser.execute_script("return window.studio.blockPoint(arguments[0])", first)
    keys = ActionChains(browser)
    keys.w3c_actions.pointer_action.move_to_location(int(point["x"]), int(point["y"]))
    keys.w3c_actions.pointer_action.click()
    keys.key_down(Keys.CONTROL).send_keys("c").send_keys("v").key_up(Keys.CONTROL)
    keys.perform()
    newest = "return window.studio.newest('bt_Action_Refuel_A')"
    copy = wait_for(lambda: (made := browser.execute_script(newest)) not in (first, second)
                    and made)  # fmt: skip
    assert browser.execute_script("return window.studio.name(arguments[0])", copy) == (
        "refuel_first_2"
    )


LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;">]>
<root BTCPP_format="4"><BehaviorTree ID="T"><Sequence name="&lol2;"/></BehaviorTree></root>
"""


def test_bad_input_in_the_page_gets_a_message_and_changes_nothing_on_disk(
    browser: Any, studio: Studio, tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    files = tmp_path_factory.mktemp("uploads")
    big = files / "big.xml"
    big.write_bytes(b"<!--" + b"x" * 2_100_000 + b"-->")
    laughs = files / "laughs.xml"
    laughs.write_text(LAUGHS, encoding="utf-8")
    browser.get(studio.url)
    wait_for(lambda: "can run" in browser.find_element("id", "message").text)
    message = browser.find_element("id", "message")

    def shows(words: str) -> bool:
        return words in message.text and "error" in (message.get_attribute("class") or "")

    for path, words in ((big, "larger than 2000 KB"), (laughs, "<!DOCTYPE")):
        browser.find_element("id", "upload").send_keys(str(path))
        wait_for(lambda words=words: shows(words))
    for field, value, words in (
        ("energy_use", "NaN", "energy_use must be a finite number"),
        ("agents", "0", "agents must be a whole number >= 1"),
    ):
        box = (
            browser.find_element("css selector", f"input[data-param='{field}']")
            if field != "agents"
            else browser.find_element("id", "agents")
        )
        original = box.get_attribute("value")
        box.clear()
        box.send_keys(value)
        browser.find_element("id", "apply").click()
        wait_for(lambda words=words: shows(words))
        box.clear()
        box.send_keys(original)
    assert list(tmp_path.iterdir()) == []


def test_paused_at_k_the_followed_drones_colours_equal_its_trace(
    browser: Any, studio: Studio
) -> None:
    from pyautonomousagent import Simulation, load

    browser.get(studio.url)
    wait_for(lambda: "can run" in browser.find_element("id", "message").text)
    browser.find_element("id", "reset").click()
    for k in range(1, 8):
        browser.find_element("id", "step").click()
        wait_for(lambda k=k: browser.execute_script("return window.studio.iteration()") == k)
    follow_agent(browser, 1)
    shown = browser.execute_script(
        "return [...document.querySelectorAll('#nodes div')].map(d => d.dataset.status)"
    )
    scenario = load("gathering")
    sim = Simulation.create(scenario, seed=0, tree=load_tree(scenario.tree))
    sim.run(progress=False, iterations=7)
    names = {0: "invalid", 1: "success", 2: "failure", 3: "running"}
    assert shown == [names[int(code)] for code in sim.recorder.trace(1)[-1]]
    labels = browser.execute_script(
        "return window.studio.workspace().getTopBlocks(true)[0].getDescendants(true)"
        ".slice(1).map(b => b.getFieldValue('STATUS'))"
    )
    shown_on_blocks = [label.split()[1] if label.startswith("●") else "invalid" for label in labels]
    assert shown_on_blocks == shown


def test_a_change_of_tree_or_parameter_during_a_run_offers_reset(
    browser: Any, studio: Studio
) -> None:
    browser.get(studio.url)
    wait_for(lambda: "can run" in browser.find_element("id", "message").text)
    button = browser.find_element
    button("id", "reset").click()
    for k in (1, 2, 3):
        button("id", "step").click()
        wait_for(lambda k=k: browser.execute_script("return window.studio.iteration()") == k)
    offer = "return window.studio.offer()"
    assert browser.execute_script(offer) == ""
    root = browser.execute_script(
        "return window.studio.workspace().getBlocksByType('bt_ReactiveSequence')[0].id"
    )
    rename(browser, root, "root")
    wait_for(lambda: "the tree changed during this run" in browser.execute_script(offer))
    assert "Reset runs the new one" in browser.execute_script(offer)
    assert "offer" in (button("id", "reset").get_attribute("class") or "")
    assert button("id", "play").get_attribute("disabled")
    assert button("id", "step").get_attribute("disabled")
    assert browser.execute_script("return window.studio.iteration()") == 3  # still shown
    button("id", "reset").click()
    wait_for(lambda: browser.execute_script(offer) == "")
    assert browser.execute_script("return window.studio.iteration()") == 0
    assert not button("id", "step").get_attribute("disabled")
    assert "offer" not in (button("id", "reset").get_attribute("class") or "")
    button("id", "step").click()
    wait_for(lambda: browser.execute_script("return window.studio.iteration()") == 1)
    box = button("css selector", "input[data-param='energy_use']")
    box.clear()
    box.send_keys("0.3")
    button("id", "apply").click()
    wait_for(lambda: "the parameters changed during this run" in browser.execute_script(offer))
    assert "Reset runs them" in button("id", "message").text
    assert button("id", "play").get_attribute("disabled")
    button("id", "reset").click()
    wait_for(lambda: browser.execute_script(offer) == "")
    assert not button("id", "play").get_attribute("disabled")


STEP = """
const done = arguments[arguments.length - 1];
fetch("/api/control", {method: "POST", body: JSON.stringify({action: "step", steps: arguments[0]})})
  .then((r) => r.json()).then(done);
"""


def test_the_map_draws_a_message_to_the_receivers_in_range_and_the_plots_the_measures(
    browser: Any, studio: Studio
) -> None:
    browser.get(studio.url)
    wait_for(lambda: "can run" in browser.find_element("id", "message").text)
    browser.find_element("id", "reset").click()
    for reached in (2500, 5002):  # the page's own request (Step steps one); two points
        browser.execute_async_script(STEP, reached - 2500 * (reached > 2500))
        wait_for(lambda r=reached: browser.execute_script("return window.studio.iteration()") == r)
    drawing = wait_for(lambda: (d := browser.execute_script("return window.studio.drawing()"))
                       and d["lines"] and d)  # fmt: skip
    assert drawing == {
        "drones": 4,
        "diamonds": 1,
        "lines": 3,  # drone1's gathering order to the three others, all in range
        "banner": "iteration 5000: gathering message from drone1 to all",
        "measures": ["alerts 0", "messages 1"],
    }
    # the diamond where the message puts the gathering (50, 50), in the GIF's purple
    assert browser.execute_script("return window.studio.pixel(50, 50)")[:3] == [148, 103, 189]
    inked = """const c = document.getElementById(arguments[0]);
        const d = c.getContext("2d").getImageData(0, 20, c.width, c.height - 20).data;
        const colours = new Set();
        for (let i = 0; i < d.length; i += 4) {
          if (d[i + 3] > 200) colours.add(d.slice(i, i + 3).join());
        }
        return [...colours].map((c) => c.split(",").map(Number));"""
    purple = (148, 103, 189)  # the messages' line is drawn on the measures plot
    assert any(
        max(abs(a - b) for a, b in zip(colour, purple, strict=True)) < 16
        for colour in browser.execute_script(inked, "measures")
    )
