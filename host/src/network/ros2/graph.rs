//! How rmw_zenoh names things on Zenoh, so that ROS 2 nodes and their
//! graph tools (`ros2 node list`, `ros2 topic list`) see Radar as one of
//! them: the key expression of a topic's data, the liveliness tokens of a
//! node and its publishers and subscriptions, the QoS written into those
//! tokens, and the attachment every message carries.

use sha2::{Digest, Sha256};

use super::settings::Qos;

/// Where rmw_zenoh declares the graph's liveliness tokens.
const ADMIN_SPACE: &str = "@ros2_lv";

/// The DDS name of a message type: `sensor_msgs::msg::dds_::Range_`.
pub fn dds_type(name: &str) -> String {
    let mut parts = name.split('/');
    match (parts.next(), parts.next(), parts.next()) {
        (Some(package), Some(kind), Some(short)) => format!("{package}::{kind}::dds_::{short}_"),
        _ => name.replace('/', "::"),
    }
}

/// The key expression of a topic's messages:
/// `<domain>/<topic without its leading slash>/<DDS type>/<type hash>`.
pub fn topic_key(domain: u32, topic: &str, type_name: &str, hash: &str) -> String {
    format!(
        "{domain}/{}/{}/{hash}",
        topic.trim_start_matches('/'),
        dds_type(type_name)
    )
}

/// The key expression that matches the liveliness token of every server
/// (`SS`) of `service` of this type and hash, whatever node holds it.
pub fn server_tokens(domain: u32, service: &str, type_name: &str, hash: &str) -> String {
    format!(
        "{ADMIN_SPACE}/{domain}/*/*/*/SS/*/*/*/{}/{}/{hash}/*",
        mangle(service),
        dds_type(type_name)
    )
}

/// A name with its slashes as `%`, as a single chunk of a key expression
/// (`/` alone is `%`).
fn mangle(name: &str) -> String {
    if name.is_empty() || name == "/" {
        "%".to_string()
    } else {
        name.replace('/', "%")
    }
}

/// Radar's node in the ROS 2 graph.
#[derive(Clone, Debug)]
pub struct Node {
    pub domain: u32,
    /// The Zenoh session's id.
    pub zid: String,
    pub namespace: String,
    pub name: String,
}

/// A publisher (`MP`), a subscription (`MS`) or a service client (`SC`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Endpoint {
    Publisher,
    Subscription,
    ServiceClient,
    ServiceServer,
}

impl Node {
    /// The node id rmw_zenoh numbers entities from: Radar has one node.
    const ID: u32 = 0;

    /// The node's liveliness token.
    pub fn token(&self) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{id}/{id}/NN/%/{}/{}",
            self.domain,
            self.zid,
            mangle(&self.namespace),
            mangle(&self.name),
            id = Self::ID,
        )
    }

    /// The liveliness token of a publisher or subscription of this node,
    /// `entity` its id (unique in the session).
    pub fn endpoint_token(
        &self,
        kind: Endpoint,
        entity: u32,
        topic: &str,
        type_name: &str,
        hash: &str,
        qos: &Qos,
    ) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{entity}/{}/%/{}/{}/{}/{}/{hash}/{}",
            self.domain,
            self.zid,
            Self::ID,
            match kind {
                Endpoint::Publisher => "MP",
                Endpoint::Subscription => "MS",
                Endpoint::ServiceClient => "SC",
                Endpoint::ServiceServer => "SS",
            },
            mangle(&self.namespace),
            mangle(&self.name),
            mangle(topic),
            dds_type(type_name),
            qos.token()
        )
    }

    /// A publisher's GID: 16 bytes, unique to this session and entity.
    pub fn gid(&self, entity: u32) -> [u8; 16] {
        let digest = Sha256::digest(format!("{}/{entity}", self.zid).as_bytes());
        let mut gid = [0; 16];
        gid.copy_from_slice(&digest[..16]);
        gid
    }
}

impl Qos {
    /// The QoS as rmw_zenoh writes it in a token: reliability, durability,
    /// `history,depth`, deadline, lifespan and liveliness, a field left
    /// empty where it is ROS 2's default (reliable, volatile, infinite);
    /// best effort is 2, transient local 1.
    pub fn token(&self) -> String {
        let reliability = if self.best_effort { "2" } else { "" };
        let durability = if self.transient_local { "1" } else { "" };
        format!("{reliability}:{durability}:,{}:,:,:,,", self.depth)
    }
}

/// The attachment rmw_zenoh sends with a message: the publisher's
/// sequence number and source timestamp (nanoseconds since the epoch),
/// each eight bytes little-endian, then its GID, preceded by its length.
pub fn attachment(sequence: i64, timestamp_ns: i64, gid: &[u8; 16]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(33);
    bytes.extend_from_slice(&sequence.to_le_bytes());
    bytes.extend_from_slice(&timestamp_ns.to_le_bytes());
    bytes.push(16);
    bytes.extend_from_slice(gid);
    bytes
}

/// An attachment's sequence number and GID (of the length it gives), if
/// it has them (see [`attachment`]).
pub fn parse_attachment(attachment: &[u8]) -> Option<(i64, &[u8])> {
    let sequence = i64::from_le_bytes(attachment.get(..8)?.try_into().ok()?);
    let gid = attachment.get(17..17 + usize::from(*attachment.get(16)?))?;
    Some((sequence, gid))
}

/// The sender's GID in an attachment, as hex, when the attachment has one.
pub fn sender(attachment: &[u8]) -> Option<String> {
    let (_, gid) = parse_attachment(attachment)?;
    Some(gid.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_attachment_reads_back_its_sequence_number_and_gid() {
        let gid = [7u8; 16];
        let bytes = attachment(42, 1_000, &gid);
        assert_eq!(parse_attachment(&bytes), Some((42, &gid[..])));
        assert_eq!(sender(&bytes).as_deref(), Some("07".repeat(16).as_str()));
        // Cut short: no GID.
        assert_eq!(parse_attachment(&bytes[..20]), None);
    }

    #[test]
    fn names_as_rmw_zenoh_does() {
        assert_eq!(
            dds_type("sensor_msgs/msg/Range"),
            "sensor_msgs::msg::dds_::Range_"
        );
        assert_eq!(
            topic_key(0, "/robot/range", "sensor_msgs/msg/Range", "RIHS01_ab"),
            "0/robot/range/sensor_msgs::msg::dds_::Range_/RIHS01_ab"
        );
        let node = Node {
            domain: 3,
            zid: "abc".into(),
            namespace: "/".into(),
            name: "radar_rover".into(),
        };
        assert_eq!(node.token(), "@ros2_lv/3/abc/0/0/NN/%/%/radar_rover");
        let qos = Qos {
            best_effort: true,
            depth: 5,
            transient_local: false,
        };
        assert_eq!(
            node.endpoint_token(Endpoint::Subscription, 2, "/range", "std_msgs/msg/Float32", "RIHS01_x", &qos),
            "@ros2_lv/3/abc/0/2/MS/%/%/radar_rover/%range/std_msgs::msg::dds_::Float32_/RIHS01_x/2::,5:,:,:,,"
        );
        let a = attachment(7, 9, &node.gid(2));
        assert_eq!(a.len(), 33);
        assert_eq!(sender(&a).expect("works").len(), 32);
        assert_eq!(sender(&[0; 10]), None);
    }
}
