//! The model's vocabulary as the token masks see it.

use token_constraint::{Token, Vocabulary, VocabularyError};

/// Converts a language model's vocabulary into the byte vocabulary of [`token_constraint`]:
/// each token's bytes, special tokens (control, unknown, unused) marked, and every stop token
/// of the model (its EOS and end-of-turn tokens) as an end of sequence.
pub fn constraint_vocabulary(vocabulary: &lm::Vocabulary) -> Result<Vocabulary, VocabularyError> {
    let tokens = vocabulary.iter().map(|(id, bytes)| Token { bytes: bytes.to_vec(), special: vocabulary.is_special(id) }).collect();
    Vocabulary::new(tokens, vocabulary.stop_tokens())
}
