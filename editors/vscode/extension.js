// Starts `atlas lsp` for .rap and .ap files (the command is the atlasRap.server.command setting).
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const [command, ...args] = vscode.workspace.getConfiguration("atlasRap").get("server.command");
  client = new LanguageClient(
    "atlas-rap",
    "atlas-rap",
    { command, args },
    { documentSelector: [{ scheme: "file", language: "rap" }, { scheme: "file", language: "ap" }] }
  );
  context.subscriptions.push(client);
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
