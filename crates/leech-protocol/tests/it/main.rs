//! Integration tests of `leech-protocol`: one binary, one module per topic.
