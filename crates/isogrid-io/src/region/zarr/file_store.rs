//! A local Zarr store that reads regular files only. zarrs' filesystem store opens whatever a key
//! names, so a FIFO in a store, as a chunk or as `.zarray`, blocked the read forever waiting for a
//! writer (and a device such as /dev/zero never ends). Every key is checked before it is read.

use zarrs::filesystem::FilesystemStore;
use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{
    MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

/// [`FilesystemStore`] that refuses a key naming anything but a regular file (or nothing).
pub(super) struct RegularFileStore(pub FilesystemStore);

impl RegularFileStore {
    /// An error when `key` names something that exists and is not a regular file (after links).
    fn check(&self, key: &StoreKey) -> Result<(), StorageError> {
        let path = self.0.key_to_fspath(key);
        match std::fs::metadata(&path) {
            Ok(meta) if !meta.is_file() && !meta.is_dir() => Err(StorageError::Other(format!(
                "{}: is not a regular file (a FIFO, socket or device)",
                path.display()
            ))),
            _ => Ok(()),
        }
    }
}

impl ReadableStorageTraits for RegularFileStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        self.check(key)?;
        self.0.get(key)
    }

    fn get_partial(
        &self,
        key: &StoreKey,
        byte_range: ByteRange,
    ) -> Result<MaybeBytes, StorageError> {
        self.check(key)?;
        self.0.get_partial(key, byte_range)
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        self.check(key)?;
        self.0.get_partial_many(key, byte_ranges)
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        self.check(key)?;
        self.0.size_key(key)
    }

    fn supports_get_partial(&self) -> bool {
        self.0.supports_get_partial()
    }
}
